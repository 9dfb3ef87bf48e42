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
