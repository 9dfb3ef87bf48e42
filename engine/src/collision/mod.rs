//! Collision stage: the signed gap, normal and lever arms of every potential
//! contact, in a canonical order (each body against each plane,
//! body-major, then each pair of bodies; within a pair, by feature) so
//! that a contact's canonical index (`Model::contact_id`) is its identity
//! from step to step. One file per shape pair; `broad.rs` finds the body
//! pairs within reach, on bounding spheres; `segment.rs` holds the
//! closest-point pieces the pairs share.

mod box_box;
mod box_plane;
mod broad;
pub use broad::Still;
mod capsule_box;
mod capsule_capsule;
mod capsule_plane;
mod cylinder;
mod hull;
mod manifold;
mod segment;
mod sphere_box;
mod sphere_capsule;
mod sphere_plane;
mod sphere_sphere;

use crate::model::state::{self, State};
use crate::model::{Counterpart, Geom, Model, Plane, Shape};
use nalgebra::Vector3;

pub use box_plane::vertex;
pub use broad::Broad;
pub use segment::{nearest_on_segment, Pose};
pub use sphere_plane::sphere_plane;
pub use sphere_sphere::sphere_sphere;

/// The geometry of one potential contact between body `a` and `b`.
#[derive(Debug, Clone, Copy)]
pub struct Geometry {
    pub a: usize,
    pub b: Counterpart,
    /// Which of the pair's contacts (below `Model::features`): 0 for a
    /// pair that touches at one point; a box's vertex, a capsule's end, a
    /// clipped point... (each pair's file).
    pub feature: usize,
    /// Signed gap: >= 0 when separated.
    pub gap: f64,
    /// Unit normal pointing from B towards A.
    pub normal: Vector3<f64>,
    /// Contact point (world), midway between the surfaces.
    pub point: Vector3<f64>,
    /// Lever arms from each centre of mass to its own surface point.
    pub r_a: Vector3<f64>,
    pub r_b: Vector3<f64>,
}

/// Scratch space of the collision stage.
#[derive(Debug, Default, Clone)]
pub struct Scratch {
    broad: Broad,
    pairs: Vec<(usize, usize)>,
}

/// Which potential contacts [`detect`] lists.
#[derive(Debug, Clone, Copy)]
pub enum Listing<'a> {
    /// Every one: the notes' enumeration, `full`, and the broad phase off.
    All,
    /// The broad phase: a pair whose gap is at most `reach[a] + reach[b] +
    /// margin`, a sphere-plane contact whose gap is at most `reach[a] +
    /// margin` (a plane is static: the sphere alone must cover the gap, its
    /// normal speed against the plane being at most its speed). The others
    /// cannot close within a step in which no body travels farther than its
    /// reach (m).
    ///
    /// With `still`, the caller vouches for the sleeping bodies as
    /// [`Still`] says, and lists the awake ones: under
    /// [`Keep::Awake`], the awake bodies look up their partners in a grid
    /// of the sleeping ones kept from call to call.
    Within {
        reach: &'a [f64],
        margin: f64,
        still: Option<Still<'a>>,
    },
    /// Those that overlap (`Within` with no reach and no margin): all that
    /// a penetration can be measured on.
    Overlapping,
}

/// Which contacts `detect` lists by their bodies' sleep (`sleep.rs`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Keep {
    /// Every one.
    Every,
    /// Those with an awake body: the step's (a contact with no awake body
    /// is not listed, `sleep::unlisted`); left out before their narrow
    /// phase, so that a sleeping pile costs no pair tests.
    Awake,
    /// Those with no awake body: what the measurements keep while asleep.
    Asleep,
}

impl Listing<'_> {
    /// Body `i`'s reach (m); none outside the broad phase's listing.
    fn reach(&self, i: usize) -> f64 {
        match self {
            Listing::Within { reach, .. } => reach[i],
            Listing::All | Listing::Overlapping => 0.0,
        }
    }

    fn margin(&self) -> f64 {
        match self {
            Listing::Within { margin, .. } => *margin,
            Listing::All | Listing::Overlapping => 0.0,
        }
    }
}

impl Geometry {
    /// The same contact seen from B: the bodies, the lever arms and the
    /// normal swapped (a pair's file computes it in one order of shapes).
    fn flipped(self) -> Geometry {
        let Counterpart::Body(b) = self.b else {
            return self;
        };
        Geometry {
            a: b,
            b: Counterpart::Body(self.a),
            normal: -self.normal,
            r_a: self.r_b,
            r_b: self.r_a,
            ..self
        }
    }

    /// The contact point on A's surface (world).
    pub fn on_a(&self, state: &State) -> Vector3<f64> {
        state.bodies[self.a].x + self.r_a
    }
}

/// Body `i`'s pose.
fn pose(state: &State, i: usize) -> Pose {
    Pose {
        x: state.bodies[i].x,
        q: state.bodies[i].q,
    }
}

/// A shape's pose in the world, its body at `body`.
fn placed(body: &Pose, g: &Geom) -> Pose {
    match g.offset {
        None => *body,
        Some(o) => Pose {
            x: body.point(&o.x),
            q: body.q * o.q,
        },
    }
}

/// The contacts `out[start..]` that a shape pair's file found with the
/// shapes' centres for the bodies' (`a_at`, `b_at`: the shapes' poses;
/// `ka`, `kb`: which of A's and B's shapes), turned into the bodies'
/// contacts: lever arms from the centres of mass, features numbered per
/// pair of shapes (`Model::shape_feature`).
fn from_shapes(
    model: &Model,
    state: &State,
    (ka, a_at): (usize, &Pose),
    (kb, b_at): (usize, Option<&Pose>),
    out: &mut [Geometry],
) {
    for g in out {
        g.feature = model.shape_feature(ka, kb, g.feature);
        g.r_a += a_at.x - state.bodies[g.a].x;
        if let (Some(b_at), Counterpart::Body(b)) = (b_at, g.b) {
            g.r_b += b_at.x - state.bodies[b].x;
        }
    }
}

/// Body `i`'s contacts with plane `p` whose gap is at most `within` (m).
pub fn body_plane(
    model: &Model,
    state: &State,
    i: usize,
    p: usize,
    within: f64,
    out: &mut Vec<Geometry>,
) {
    let plane: &Plane = &model.planes[p];
    let body = pose(state, i);
    for (k, g) in model.bodies[i].shapes.iter().enumerate() {
        let start = out.len();
        let at = placed(&body, g);
        shape_plane(model, g.shape, i, &at, p, plane, within, out);
        if g.offset.is_some() || k > 0 {
            from_shapes(model, state, (k, &at), (0, None), &mut out[start..]);
        }
    }
}

/// One shape of body `i`, at `at`, against plane `p`.
#[allow(clippy::too_many_arguments)]
fn shape_plane(
    model: &Model,
    shape: Shape,
    i: usize,
    at: &Pose,
    p: usize,
    plane: &Plane,
    within: f64,
    out: &mut Vec<Geometry>,
) {
    match shape {
        Shape::Sphere { radius } => {
            let g = sphere_plane(i, at.x, radius, p, plane);
            if g.gap <= within {
                out.push(g);
            }
        }
        Shape::Box { half } => box_plane::box_plane(i, at, &half, p, plane, within, out),
        Shape::Capsule {
            radius,
            half_length,
        } => capsule_plane::capsule_plane(i, at, (radius, half_length), p, plane, within, out),
        Shape::Hull {
            cylinder: Some(rl), ..
        } => cylinder::cylinder_plane(i, at, rl, p, plane, within, out),
        Shape::Hull { index, .. } => {
            hull::hull_plane(i, at, &model.hulls[index], p, plane, within, out)
        }
    }
}

/// The contacts of bodies `i < j` whose gap is at most `within` (m), in
/// ascending feature (a pair of spheres' one contact whatever its gap):
/// each shape of `i` against each of `j`.
pub fn body_pair(
    model: &Model,
    state: &State,
    i: usize,
    j: usize,
    within: f64,
    out: &mut Vec<Geometry>,
) {
    let (bi, bj) = (pose(state, i), pose(state, j));
    let (si, sj) = (&model.bodies[i].shapes, &model.bodies[j].shapes);
    for (ka, ga) in si.iter().enumerate() {
        for (kb, gb) in sj.iter().enumerate() {
            let start = out.len();
            let (pa, pb) = (placed(&bi, ga), placed(&bj, gb));
            // Both at their centres of mass: a body's one shape, computed
            // as it always was.
            let centred = ga.offset.is_none() && gb.offset.is_none();
            shape_pair(model, (i, ga, &pa), (j, gb, &pb), within, centred, out);
            if !centred || ka > 0 || kb > 0 {
                from_shapes(model, state, (ka, &pa), (kb, Some(&pb)), &mut out[start..]);
            }
        }
    }
}

/// Shape `si` of body `i` at `pi` against shape `sj` of body `j` at `pj`.
/// `centred`: both shapes are their bodies' one shape at the centre of
/// mass, where a pair of spheres is listed whatever its gap.
fn shape_pair(
    model: &Model,
    (i, gi, pi): (usize, &Geom, &Pose),
    (j, gj, pj): (usize, &Geom, &Pose),
    within: f64,
    centred: bool,
    out: &mut Vec<Geometry>,
) {
    use Shape::{Box, Capsule, Hull, Sphere};
    // Each pair's file takes its shapes in one order (sphere, capsule,
    // box, hull): a pair in the other order is computed as (j, i) and
    // flipped.
    let rank = |s: &Shape| match s {
        Sphere { .. } => 0,
        Capsule { .. } => 1,
        Box { .. } => 2,
        Hull { .. } => 3,
    };
    let flip = rank(&gi.shape) > rank(&gj.shape);
    let ((a, ga, pa), (b, gb, pb)) = if flip {
        ((j, gj, *pj), (i, gi, *pi))
    } else {
        ((i, gi, *pi), (j, gj, *pj))
    };
    let (sa, sb) = (ga.shape, gb.shape);
    let hulls = &model.hulls;
    let start = out.len();
    match (sa, sb) {
        // Listed whatever `within` says: the broad phase's test for a pair
        // of spheres is this very gap (`broad.rs`), and repeating it in
        // another order of sums could drop a pair it kept by a rounding.
        (Sphere { radius: ra }, Sphere { radius: rb }) => {
            let g = sphere_sphere(a, pa.x, ra, b, pb.x, rb);
            if centred || g.gap <= within {
                out.push(g);
            }
        }
        (Sphere { radius }, Box { half }) => {
            let g = sphere_box::ball_box(a, pa.x, radius, None, b, &pb, &half, 0);
            if g.gap <= within {
                out.push(g);
            }
        }
        (
            Sphere { radius },
            Capsule {
                radius: rc,
                half_length,
            },
        ) => {
            let g = sphere_capsule::sphere_capsule(a, pa.x, radius, b, &pb, rc, half_length);
            if g.gap <= within {
                out.push(g);
            }
        }
        (
            Capsule {
                radius: ra,
                half_length: la,
            },
            Capsule {
                radius: rb,
                half_length: lb,
            },
        ) => capsule_capsule::capsule_capsule(a, &pa, (ra, la), b, &pb, (rb, lb), within, out),
        (
            Capsule {
                radius,
                half_length,
            },
            Box { half },
        ) => capsule_box::capsule_box(a, &pa, (radius, half_length), b, &pb, &half, within, out),
        (Box { half: ha }, Box { half: hb }) => {
            box_box::box_box(a, &pa, &ha, b, &pb, &hb, within, out)
        }
        (
            Sphere { radius },
            Hull {
                index, cylinder, ..
            },
        ) => {
            let g = match cylinder {
                Some(rl) => cylinder::ball_cylinder(a, pa.x, radius, None, b, &pb, rl, 0),
                None => hull::ball_hull(a, pa.x, radius, None, b, &pb, &hulls[index], 0),
            };
            if g.gap <= within {
                out.push(g);
            }
        }
        (
            Capsule {
                radius,
                half_length,
            },
            Hull {
                cylinder: Some(rl), ..
            },
        ) => cylinder::capsule_cylinder(a, &pa, (radius, half_length), b, &pb, rl, within, out),
        (
            Capsule {
                radius,
                half_length,
            },
            Hull { index, .. },
        ) => hull::capsule_hull(
            a,
            &pa,
            (radius, half_length),
            b,
            &pb,
            &hulls[index],
            within,
            out,
        ),
        (
            Box { .. },
            Hull {
                index, cylinder, ..
            },
        ) => {
            // A box in a scene with hulls has its hull (`Geom::hull`).
            if let Some(h) = ga.hull {
                let wider = within + cylinder.map_or(0.0, cylinder::prism_slack);
                hull::hull_hull(a, &pa, &hulls[h], b, &pb, &hulls[index], wider, out);
                if let Some(rl) = cylinder {
                    cylinder::on_face(false, &pb, rl, &pa, &hulls[h], within, start, out);
                }
            }
        }
        (
            Hull {
                index: ia,
                cylinder: ca,
                ..
            },
            Hull {
                index: ib,
                cylinder: cb,
                ..
            },
        ) => {
            let slack = match (ca, cb) {
                (Some(rl), None) | (None, Some(rl)) => cylinder::prism_slack(rl),
                (Some(x), Some(y)) => cylinder::prism_slack(x) + cylinder::prism_slack(y),
                (None, None) => 0.0,
            };
            hull::hull_hull(a, &pa, &hulls[ia], b, &pb, &hulls[ib], within + slack, out);
            // A cylinder on a hull: its true rim on a face, or the hull's
            // edges on its true surface; two cylinders' round sides as
            // two capsules'.
            match (ca, cb) {
                (Some(rl), None) => {
                    cylinder::on_face(true, &pa, rl, &pb, &hulls[ib], within, start, out)
                }
                (None, Some(rl)) => {
                    cylinder::on_face(false, &pb, rl, &pa, &hulls[ia], within, start, out)
                }
                (Some(x), Some(y)) => {
                    cylinder::cylinder_cylinder(a, &pa, x, b, &pb, y, within, start, out)
                }
                (None, None) => {}
            }
        }
        // Ordered by rank above.
        (Capsule { .. } | Box { .. } | Hull { .. }, Sphere { .. })
        | (Box { .. } | Hull { .. }, Capsule { .. })
        | (Hull { .. }, Box { .. }) => {
            unreachable!("a pair is taken in the rank's order")
        }
    }
    if flip {
        for g in &mut out[start..] {
            *g = g.flipped();
        }
    }
}

/// Fills `out` with the potential contacts of the scene that `listing`
/// names and `keep` keeps, in canonical order: every body against every
/// plane, then the body pairs. With `sphere_contacts = false` there are no
/// pairs; they come last in the order, so the other contacts keep their
/// identities.
pub fn detect(
    model: &Model,
    state: &State,
    listing: Listing,
    keep: Keep,
    scratch: &mut Scratch,
    out: &mut Vec<Geometry>,
) {
    out.clear();
    // Without a sleeping body, `Awake` is `Every` and `Asleep` is none.
    let keep = match (keep, state::any_asleep(state)) {
        (Keep::Asleep, false) => return,
        (Keep::Awake, false) => Keep::Every,
        (k, _) => k,
    };
    let kept = |i: usize, b: Counterpart| match keep {
        Keep::Every => true,
        Keep::Awake => !state::unlisted(state, i, b),
        Keep::Asleep => state::unlisted(state, i, b),
    };
    let all = matches!(listing, Listing::All);
    // The gap up to which a contact is listed: none beyond for `All`.
    let within = |reach: f64| {
        if all {
            f64::INFINITY
        } else {
            reach + listing.margin()
        }
    };
    let bound = |i: usize| model.bodies[i].bound;
    // The caller's list of the awake bodies, where it vouches for the
    // sleeping ones (`Listing::Within`): only those bodies' contacts are
    // kept.
    let still = match (keep, &listing) {
        (Keep::Awake, Listing::Within { still, .. }) => *still,
        _ => None,
    };
    let (mut every, mut listed) = (
        0..model.bodies.len(),
        still.map(|s| s.active.iter().map(|&i| i as usize)),
    );
    let bodies: &mut dyn Iterator<Item = usize> = match &mut listed {
        Some(listed) => listed,
        None => &mut every,
    };
    for i in bodies {
        // A body welded to the world is the world's (`Model::weld`).
        if model.weld[i] == crate::model::WELDED_TO_WORLD {
            continue;
        }
        // Whether a body's plane contacts are kept is the body's alone
        // (`sleep::unlisted`): asked once, not once per plane.
        if !kept(i, Counterpart::Plane(0)) {
            continue;
        }
        let x = state.bodies[i].x;
        for (p, plane) in model.planes.iter().enumerate() {
            let w = within(listing.reach(i));
            // The bounding sphere's gap bounds every feature's from below.
            if plane.normal.dot(&x) - plane.offset - bound(i) > w {
                continue;
            }
            body_plane(model, state, i, p, w, out);
        }
    }
    if !model.params.sphere_contacts {
        return;
    }
    let n = model.bodies.len();
    let apart = |&(i, j): &(usize, usize)| model.may_touch(i, j) && kept(i, Counterpart::Body(j));
    if all {
        for i in 0..n {
            for j in i + 1..n {
                if apart(&(i, j)) {
                    body_pair(model, state, i, j, f64::INFINITY, out);
                }
            }
        }
        return;
    }
    let Scratch { broad, pairs } = scratch;
    let reach = |i| listing.reach(i);
    broad.pairs(
        n,
        |i| state.bodies[i].x,
        bound,
        reach,
        listing.margin(),
        // Only the awake bodies look for partners when those are kept.
        |i| keep != Keep::Awake || !state::asleep(state, i),
        still,
        pairs,
    );
    for &(i, j) in pairs.iter().filter(|p| apart(p)) {
        body_pair(model, state, i, j, within(reach(i) + reach(j)), out);
    }
}

/// Where shape contact `id` touches on its body A's surface in `state`
/// (world), recomputed from the poses: what the figures, the recordings
/// and the live view draw a contact's force from. `None` for a joint
/// limit's id or a feature the pair does not have in this state.
pub fn contact_point(model: &Model, state: &State, id: usize) -> Option<Vector3<f64>> {
    contact_geometry(model, state, id, &mut Vec::new()).map(|g| g.on_a(state))
}

/// The geometry of potential contact `id` at the state's poses, `found`
/// the narrow phase's scratch. `None` as for [`contact_point`].
pub fn contact_geometry(
    model: &Model,
    state: &State,
    id: usize,
    found: &mut Vec<Geometry>,
) -> Option<Geometry> {
    if id >= model.potential_contacts() {
        return None;
    }
    let (a, b) = model.contact_bodies(id);
    let feature = model.contact_feature(id);
    found.clear();
    match b {
        Counterpart::Plane(p) => body_plane(model, state, a, p, f64::INFINITY, found),
        Counterpart::Body(j) => body_pair(model, state, a, j, f64::INFINITY, found),
        Counterpart::World => return None,
    }
    found.iter().find(|g| g.feature == feature).copied()
}
