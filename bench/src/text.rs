//! Scene text for the benchmark cases: one `[[body]]`, `[[plane]]` or
//! `[[joint]]` table each, appended to a `[sim]` header.

/// A `[[body]]` sphere. Keys appended right after it (`force`) belong to it.
#[allow(clippy::too_many_arguments)]
pub fn sphere(name: &str, r: f64, m: f64, x: [f64; 3], v: [f64; 3], mu: f64, e: f64) -> String {
    format!(
        "[[body]]\nname = \"{name}\"\nradius = {r:e}\nmass = {m:e}\nposition = [{:e}, {:e}, {:e}]\nvelocity = [{:e}, {:e}, {:e}]\nfriction = {mu:e}\nrestitution = {e:e}\n",
        x[0], x[1], x[2], v[0], v[1], v[2]
    )
}

/// A body's pose and motion lines: position, orientation (`[w, x, y, z]`),
/// velocity, angular velocity.
fn motion(x: [f64; 3], q: [f64; 4], v: [f64; 3], w: [f64; 3]) -> String {
    format!(
        "position = [{:e}, {:e}, {:e}]\norientation = [{:e}, {:e}, {:e}, {:e}]\nvelocity = [{:e}, {:e}, {:e}]\nangular_velocity = [{:e}, {:e}, {:e}]\n",
        x[0], x[1], x[2], q[0], q[1], q[2], q[3], v[0], v[1], v[2], w[0], w[1], w[2]
    )
}

/// A `[[body]]` of the shape `lines` give, turned by `q` (`[w, x, y, z]`),
/// moving at `v` and `w`.
#[allow(clippy::too_many_arguments)]
fn shaped(
    name: &str,
    lines: &str,
    m: f64,
    x: [f64; 3],
    q: [f64; 4],
    v: [f64; 3],
    w: [f64; 3],
    mu: f64,
) -> String {
    format!(
        "[[body]]\nname = \"{name}\"\n{lines}mass = {m:e}\n{}friction = {mu:e}\n",
        motion(x, q, v, w)
    )
}

/// A `[[body]]` box of half extents `half`, turned by `q` (`[w, x, y, z]`),
/// moving at `v` and `w`.
#[allow(clippy::too_many_arguments)]
pub fn cuboid(
    name: &str,
    half: [f64; 3],
    m: f64,
    x: [f64; 3],
    q: [f64; 4],
    v: [f64; 3],
    w: [f64; 3],
    mu: f64,
) -> String {
    let [a, b, c] = half;
    let lines = format!("half_extents = [{a:e}, {b:e}, {c:e}]\n");
    shaped(name, &lines, m, x, q, v, w, mu)
}

/// A `[[body]]` capsule of radius `r` about a segment of half length `l`
/// along its body z axis, turned by `q`, moving at `v` and `w`.
#[allow(clippy::too_many_arguments)]
pub fn capsule(
    name: &str,
    r: f64,
    l: f64,
    m: f64,
    x: [f64; 3],
    q: [f64; 4],
    v: [f64; 3],
    w: [f64; 3],
    mu: f64,
) -> String {
    let lines = format!("radius = {r:e}\nhalf_length = {l:e}\n");
    shaped(name, &lines, m, x, q, v, w, mu)
}

/// The constant force of the body just written.
pub fn force(f: [f64; 3]) -> String {
    format!("force = [{:e}, {:e}, {:e}]\n", f[0], f[1], f[2])
}

/// A `[[plane]]` through `point` with normal `n`.
pub fn plane(name: &str, n: [f64; 3], point: [f64; 3], mu: f64, e: f64) -> String {
    format!(
        "[[plane]]\nname = \"{name}\"\nnormal = [{:e}, {:e}, {:e}]\npoint = [{:e}, {:e}, {:e}]\nfriction = {mu:e}\nrestitution = {e:e}\n",
        n[0], n[1], n[2], point[0], point[1], point[2]
    )
}

/// A spherical `[[joint]]`.
pub fn joint(name: &str, a: &str, b: &str, anchor: [f64; 3]) -> String {
    format!(
        "[[joint]]\nname = \"{name}\"\ntype = \"spherical\"\nbody_a = \"{a}\"\nbody_b = \"{b}\"\nanchor = [{:e}, {:e}, {:e}]\n",
        anchor[0], anchor[1], anchor[2]
    )
}

/// A revolute `[[joint]]` about `axis` (a world direction at t = 0).
pub fn hinge(name: &str, a: &str, b: &str, anchor: [f64; 3], axis: [f64; 3]) -> String {
    format!(
        "[[joint]]\nname = \"{name}\"\ntype = \"revolute\"\nbody_a = \"{a}\"\nbody_b = \"{b}\"\nanchor = [{:e}, {:e}, {:e}]\naxis = [{:e}, {:e}, {:e}]\ncollide = false\n",
        anchor[0], anchor[1], anchor[2], axis[0], axis[1], axis[2]
    )
}
