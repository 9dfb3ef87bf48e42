//! Validation: every field of a parsed scene checked, the error naming it.

use super::*;

impl Scene {
    pub fn validate(&self, file: &str) -> Result<(), SceneError> {
        let err = |field: String, message: String| SceneError {
            file: file.to_string(),
            location: None,
            field,
            message,
        };
        if let Some(r) = self.robots.first() {
            return Err(err(
                "robot".into(),
                format!(
                    "= {:?}: a robot is placed by the importer: run the scene with cosim-server \
                     (or read it with cosim_import::scene::load)",
                    r.file
                ),
            ));
        }
        let sim = &self.sim;
        positive(sim.dt).map_err(|m| err("sim.dt".into(), m))?;
        match (sim.duration, sim.steps) {
            (Some(_), Some(_)) => {
                return Err(err(
                    "sim.steps".into(),
                    "give either sim.duration or sim.steps, not both".into(),
                ))
            }
            (None, None) => {
                return Err(err(
                    "sim.duration".into(),
                    "missing: give sim.duration (seconds) or sim.steps".into(),
                ))
            }
            (Some(t), None) => positive(t).map_err(|m| err("sim.duration".into(), m))?,
            (None, Some(0)) => {
                return Err(err("sim.steps".into(), "= 0: must be at least 1".into()))
            }
            (None, Some(_)) => {}
        }
        finite3(&sim.gravity).map_err(|m| err("sim.gravity".into(), m))?;
        if !(3..=64).contains(&sim.friction_directions) {
            return Err(err(
                "sim.friction_directions".into(),
                format!(
                    "= {}: must be between 3 and 64 (an even number keeps straight sliding exact)",
                    sim.friction_directions
                ),
            ));
        }
        if sim.friction_cone == FrictionCone::Circular && sim.solver != SolverChoice::Pgs {
            return Err(err(
                "sim.friction_cone".into(),
                format!(
                    "= \"circular\" needs solver = \"pgs\" (solver is {:?}): Lemke's LCP has the polyhedral cone",
                    sim.solver.as_str()
                ),
            ));
        }
        if !(sim.beta.is_finite() && sim.beta > 0.0 && sim.beta <= 1.0) {
            return Err(err(
                "sim.beta".into(),
                format!("= {}: must lie in (0, 1]", sim.beta),
            ));
        }
        nonneg(sim.restitution_threshold)
            .map_err(|m| err("sim.restitution_threshold".into(), m))?;
        nonneg(sim.contact_margin).map_err(|m| err("sim.contact_margin".into(), m))?;
        {
            let sleep = &sim.sleep;
            nonneg(sleep.after).map_err(|m| err("sim.sleep.after".into(), m))?;
            positive(sleep.linear_speed).map_err(|m| err("sim.sleep.linear_speed".into(), m))?;
            positive(sleep.angular_speed).map_err(|m| err("sim.sleep.angular_speed".into(), m))?;
        }
        if let Some(pgs) = &sim.pgs {
            positive(pgs.tolerance).map_err(|m| err("sim.pgs.tolerance".into(), m))?;
            if !(0.0..1.0).contains(&pgs.relative) {
                return Err(err(
                    "sim.pgs.relative".into(),
                    format!("= {}: must be in [0, 1)", pgs.relative),
                ));
            }
            if pgs.max_iterations == 0 {
                return Err(err(
                    "sim.pgs.max_iterations".into(),
                    "= 0: must be at least 1".into(),
                ));
            }
        }

        // (name, field that first used it), to refuse duplicates by name.
        let mut names: Vec<(String, String)> = Vec::new();
        let mut claim = |name: &str, field: String| -> Result<(), SceneError> {
            if name.trim().is_empty() {
                return Err(err(field, "is empty: every object needs a name".into()));
            }
            if name == WORLD {
                return Err(err(
                    field,
                    format!("= {name:?}: the name {WORLD:?} is reserved for the fixed world"),
                ));
            }
            if let Some((_, first)) = names.iter().find(|(n, _)| n == name) {
                return Err(err(
                    field,
                    format!("= {name:?}: duplicate name, already used by {first}"),
                ));
            }
            names.push((name.to_string(), field));
            Ok(())
        };

        for (i, b) in self.bodies.iter().enumerate() {
            claim(&b.name, format!("body[{i}].name"))?;
            let f = |k: &str| format!("body {:?}.{k}", b.name);
            if !b.shape.is_empty() && b.has_own_shape() {
                return Err(err(
                    f("shape"),
                    "with radius, half_length or half_extents: give a body's shape by \
                     its own fields or its shapes by [[body.shape]], not both"
                        .into(),
                ));
            }
            if b.has_own_shape() || b.shape.is_empty() && b.inertia.is_none() {
                check_shape(b.shape_or_error(), &f).map_err(|(k, m)| err(k, m))?;
            }
            for (k, e) in b.shape.iter().enumerate() {
                let g = |key: &str| f(&format!("shape[{k}].{key}"));
                check_shape(e.shape_or_error(), &g).map_err(|(k, m)| err(k, m))?;
                finite3(&e.position).map_err(|m| err(g("position"), m))?;
                unit_quaternion(&e.orientation).map_err(|m| err(g("orientation"), m))?;
            }
            for (k, e) in b.frame.iter().enumerate() {
                let g = |key: &str| f(&format!("frame[{k}].{key}"));
                claim(&e.name, g("name"))?;
                finite3(&e.position).map_err(|m| err(g("position"), m))?;
                unit_quaternion(&e.orientation).map_err(|m| err(g("orientation"), m))?;
            }
            for (k, v) in b.visual.iter().enumerate() {
                let g = |key: &str| f(&format!("visual[{k}].{key}"));
                if let Some((key, m)) = v.problem() {
                    return Err(err(g(key), m));
                }
                finite3(&v.position).map_err(|m| err(g("position"), m))?;
                unit_quaternion(&v.orientation).map_err(|m| err(g("orientation"), m))?;
            }
            let shapes = b.shapes();
            let centred = shapes.iter().all(|p| p.centred());
            let hull = shapes
                .iter()
                .any(|p| matches!(p.shape, ShapeDesc::Hull { .. }));
            if b.inertia.is_none()
                && (hull || !(b.shape.is_empty() || b.shape.len() == 1 && centred))
            {
                return Err(err(
                    f("inertia"),
                    "is missing: a body with no shape, several, a hull, or one away from \
                     its centre of mass needs its inertia [ixx, iyy, izz, ixy, ixz, iyz] \
                     (about the centre of mass, in the body's frame)"
                        .into(),
                ));
            }
            positive(b.mass).map_err(|m| err(f("mass"), m))?;
            if let Some(j) = b.inertia {
                // Positive definite: the leading minors of the symmetric
                // matrix are positive (Sylvester).
                let [xx, yy, zz, xy, xz, yz] = j;
                let minors = [
                    xx,
                    xx * yy - xy * xy,
                    xx * (yy * zz - yz * yz) - xy * (xy * zz - yz * xz) + xz * (xy * yz - yy * xz),
                ];
                if !j.iter().all(|x| x.is_finite()) || minors.iter().any(|&m| m <= 0.0) {
                    return Err(err(
                        f("inertia"),
                        format!(
                            "= {j:?}: [ixx, iyy, izz, ixy, ixz, iyz] must be finite and \
                             positive definite"
                        ),
                    ));
                }
                let least = smallest_moment(j);
                if least < MIN_MOMENT {
                    return Err(err(
                        f("inertia"),
                        format!(
                            "= {j:?}: its smallest principal moment {least:e} kg m^2 is under \
                             {MIN_MOMENT:e}: its inverse would swamp every other row of the step \
                             (a 1 g part 5 mm across has 1e-8)"
                        ),
                    ));
                }
            }
            finite3(&b.position).map_err(|m| err(f("position"), m))?;
            finite3(&b.velocity).map_err(|m| err(f("velocity"), m))?;
            finite3(&b.angular_velocity).map_err(|m| err(f("angular_velocity"), m))?;
            finite3(&b.force).map_err(|m| err(f("force"), m))?;
            unit_quaternion(&b.orientation).map_err(|m| err(f("orientation"), m))?;
            nonneg(b.friction).map_err(|m| err(f("friction"), m))?;
            unit_interval(b.restitution).map_err(|m| err(f("restitution"), m))?;
        }
        for (i, p) in self.planes.iter().enumerate() {
            claim(&p.name, format!("plane[{i}].name"))?;
            let f = |k: &str| format!("plane {:?}.{k}", p.name);
            finite3(&p.normal).map_err(|m| err(f("normal"), m))?;
            finite3(&p.point).map_err(|m| err(f("point"), m))?;
            let len2: f64 = p.normal.iter().map(|x| x * x).sum();
            if len2 <= 1e-24 {
                return Err(err(
                    f("normal"),
                    format!("= {:?}: a plane's normal must not be zero", p.normal),
                ));
            }
            nonneg(p.friction).map_err(|m| err(f("friction"), m))?;
            unit_interval(p.restitution).map_err(|m| err(f("restitution"), m))?;
        }
        for (i, j) in self.joints.iter().enumerate() {
            claim(&j.name, format!("joint[{i}].name"))?;
            let f = |k: &str| format!("joint {:?}.{k}", j.name);
            // What only a hinge or a slider has: a coordinate and its axis.
            let axial_only = |field: &str, what: &str| -> Result<(), SceneError> {
                match j.kind {
                    JointKind::Revolute | JointKind::Prismatic => Ok(()),
                    kind => Err(err(
                        f(field),
                        format!(
                            "only a revolute or prismatic joint has {what} (this one is {})",
                            kind.as_str()
                        ),
                    )),
                }
            };
            for (key, body) in [("body_a", &j.body_a), ("body_b", &j.body_b)] {
                if body != WORLD && !self.bodies.iter().any(|b| &b.name == body) {
                    let known: Vec<&str> = self.bodies.iter().map(|b| b.name.as_str()).collect();
                    return Err(err(
                        f(key),
                        format!(
                            "= {body:?}: unknown body (known: \"world\", {})",
                            known
                                .iter()
                                .map(|n| format!("{n:?}"))
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    ));
                }
            }
            if j.body_a == j.body_b {
                return Err(err(
                    f("body_b"),
                    format!("= {:?}: a joint needs two different bodies", j.body_b),
                ));
            }
            finite3(&j.anchor).map_err(|m| err(f("anchor"), m))?;
            finite3(&j.torque).map_err(|m| err(f("torque"), m))?;
            match (j.kind, j.force) {
                (JointKind::Prismatic, Some(force)) => {
                    finite3(&force).map_err(|m| err(f("force"), m))?
                }
                (kind, Some(_)) => {
                    return Err(err(
                        f("force"),
                        format!(
                            "only a prismatic joint has a force (this one is {}: its effort is a torque)",
                            kind.as_str()
                        ),
                    ))
                }
                (_, None) => {}
            }
            if j.kind == JointKind::Prismatic && j.torque != [0.0; 3] {
                return Err(err(
                    f("torque"),
                    "a prismatic joint's effort is a force: give `force`".into(),
                ));
            }
            match (j.kind, j.range) {
                (JointKind::Revolute | JointKind::Prismatic, Some([lo, hi])) => {
                    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                        return Err(err(
                            f("range"),
                            format!("= [{lo}, {hi}]: needs finite bounds with lower < upper"),
                        ));
                    }
                    let pi = std::f64::consts::PI;
                    if j.kind == JointKind::Revolute && (lo < -pi || hi > pi) {
                        return Err(err(
                            f("range"),
                            format!(
                                "= [{lo}, {hi}]: a hinge's limits are angles within [-pi, pi] (rad)"
                            ),
                        ));
                    }
                }
                (_, Some(_)) => axial_only("range", "a range")?,
                (_, None) => {}
            }
            if let Some(q) = j.position {
                axial_only("position", "a coordinate")?;
                let pi = std::f64::consts::PI;
                let (lo, hi) = match (j.kind, j.range) {
                    (_, Some([lo, hi])) => (lo, hi),
                    (JointKind::Revolute, None) => (-pi, pi),
                    _ => (f64::NEG_INFINITY, f64::INFINITY),
                };
                if !(q.is_finite() && (lo..=hi).contains(&q)) {
                    return Err(err(
                        f("position"),
                        format!("= {q}: must be finite and within [{lo}, {hi}]"),
                    ));
                }
            }
            if let Some(motor) = j.motor {
                axial_only("motor", "a motor")?;
                if !motor.speed.is_finite() {
                    return Err(err(
                        f("motor.speed"),
                        format!("= {}: must be finite", motor.speed),
                    ));
                }
                match (motor.position, motor.kp, motor.kd, motor.kv) {
                    (Some(q), kp, kd, None) => {
                        if !q.is_finite() {
                            return Err(err(f("motor.position"), format!("= {q}: must be finite")));
                        }
                        if motor.speed != 0.0 {
                            return Err(err(
                                f("motor.speed"),
                                "a position servo has no speed: give `position` or `speed`".into(),
                            ));
                        }
                        let Some(kp) = kp else {
                            return Err(err(
                                f("motor.kp"),
                                "missing: a position servo needs its stiffness kp".into(),
                            ));
                        };
                        positive(kp).map_err(|m| err(f("motor.kp"), m))?;
                        nonneg(kd.unwrap_or(0.0)).map_err(|m| err(f("motor.kd"), m))?;
                    }
                    (Some(_), _, _, Some(_)) => {
                        return Err(err(
                            f("motor.kv"),
                            "a position servo's gains are kp and kd, not kv".into(),
                        ))
                    }
                    (None, Some(_), _, _) | (None, _, Some(_), _) => {
                        return Err(err(
                            f("motor.kp"),
                            "kp and kd are a position servo's: give its `position`".into(),
                        ))
                    }
                    (None, None, None, kv) => {
                        if let Some(kv) = kv {
                            positive(kv).map_err(|m| err(f("motor.kv"), m))?;
                        }
                    }
                }
                positive(motor.max_effort).map_err(|m| err(f("motor.max_effort"), m))?;
            }
            if let Some(e) = j.max_effort {
                if j.kind == JointKind::Fixed {
                    return Err(err(
                        f("max_effort"),
                        "a fixed joint takes no effort: it has nothing to drive".into(),
                    ));
                }
                positive(e).map_err(|m| err(f("max_effort"), m))?;
            }
            if let Some(a) = j.armature {
                if j.kind == JointKind::Fixed {
                    return Err(err(
                        f("armature"),
                        "a fixed joint has no coordinate for a rotor to turn with".into(),
                    ));
                }
                nonneg(a).map_err(|m| err(f("armature"), m))?;
            }
            if let Some(e) = j.limit_restitution {
                if j.range.is_none() {
                    return Err(err(
                        f("limit_restitution"),
                        "a limit's restitution needs the joint's `range`".into(),
                    ));
                }
                unit_interval(e).map_err(|m| err(f("limit_restitution"), m))?;
            }
            match (j.kind, j.axis) {
                (kind @ (JointKind::Revolute | JointKind::Prismatic), None) => {
                    return Err(err(
                        f("axis"),
                        format!("missing: a {} joint needs its axis", kind.as_str()),
                    ))
                }
                (JointKind::Revolute | JointKind::Prismatic, Some(a)) => {
                    finite3(&a).map_err(|m| err(f("axis"), m))?;
                    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
                    if !(n > 1e-9 && n.is_finite()) {
                        return Err(err(
                            f("axis"),
                            format!("= {a:?}: the axis needs a direction (not zero)"),
                        ));
                    }
                }
                (_, Some(_)) => axial_only("axis", "an axis")?,
                (_, None) => {}
            }
            if let Some(m) = &j.mimic {
                axial_only("mimic", "a coordinate to couple")?;
                let leader = self.joints.iter().find(|l| l.name == m.joint);
                match leader {
                    None => {
                        return Err(err(
                            f("mimic.joint"),
                            format!("= {:?}: no joint of that name", m.joint),
                        ))
                    }
                    Some(l) if l.name == j.name => {
                        return Err(err(f("mimic.joint"), "a joint cannot follow itself".into()))
                    }
                    Some(l) if !matches!(l.kind, JointKind::Revolute | JointKind::Prismatic) => {
                        return Err(err(
                            f("mimic.joint"),
                            format!(
                                "= {:?}: a {} joint has no coordinate to follow",
                                m.joint,
                                l.kind.as_str()
                            ),
                        ))
                    }
                    Some(_) => {}
                }
                for (key, x) in [("multiplier", m.multiplier), ("offset", m.offset)] {
                    if !x.is_finite() {
                        return Err(err(
                            f(&format!("mimic.{key}")),
                            format!("= {x}: must be finite"),
                        ));
                    }
                }
                // It starts where its leader puts it: a rigid coupling
                // started off would close the gap in one step, with the
                // energy of that speed (the importers place followers so).
                let lead = leader.and_then(|l| l.position).unwrap_or(0.0);
                let (want, at) = (m.multiplier * lead + m.offset, j.position.unwrap_or(0.0));
                let mut off = at - want;
                if j.kind == JointKind::Revolute {
                    use std::f64::consts::{PI, TAU};
                    off = (off + PI).rem_euclid(TAU) - PI;
                }
                if off.abs() > 1e-9 * want.abs().max(1.0) {
                    return Err(err(
                        f("position"),
                        format!(
                            "= {at}: it follows {:?} (at {lead}), which puts it at {want}: start it there",
                            m.joint
                        ),
                    ));
                }
                // A loop of followers would tie a coordinate to itself.
                let mut at = m.joint.as_str();
                for _ in 0..self.joints.len() {
                    let Some(next) = self
                        .joints
                        .iter()
                        .find(|l| l.name == at)
                        .and_then(|l| l.mimic.as_ref())
                    else {
                        break;
                    };
                    if next.joint == j.name {
                        return Err(err(
                            f("mimic.joint"),
                            format!(
                                "= {:?}: the followers form a loop back to this joint",
                                m.joint
                            ),
                        ));
                    }
                    at = &next.joint;
                }
            }
        }
        if let Some(c) = &self.compliance {
            for (what, spring) in [("contact", c.contact), ("joint", c.joint)] {
                if let Some(k) = spring {
                    positive(k.stiffness)
                        .map_err(|m| err(format!("compliance.{what}.stiffness"), m))?;
                    nonneg(k.damping).map_err(|m| err(format!("compliance.{what}.damping"), m))?;
                }
            }
        }
        if let Some(c) = &self.camera {
            if let Some(d) = &c.direction {
                finite3(d).map_err(|m| err("camera.direction".into(), m))?;
                if d.iter().map(|x| x * x).sum::<f64>() <= 1e-24 {
                    return Err(err(
                        "camera.direction".into(),
                        format!("= {d:?}: must not be zero"),
                    ));
                }
            }
            if let Some(t) = &c.target {
                finite3(t).map_err(|m| err("camera.target".into(), m))?;
            }
            if let Some(w) = c.width {
                positive(w).map_err(|m| err("camera.width".into(), m))?;
            }
        }
        Ok(())
    }
}

/// The smallest principal moment of inertia a body may have (kg m^2).
pub const MIN_MOMENT: f64 = 1e-12;

/// The smallest eigenvalue of the symmetric inertia `[ixx, iyy, izz, ixy,
/// ixz, iyz]` (the closed form for a symmetric 3x3 matrix).
pub(super) fn smallest_moment([xx, yy, zz, xy, xz, yz]: [f64; 6]) -> f64 {
    let off = xy * xy + xz * xz + yz * yz;
    if off == 0.0 {
        return xx.min(yy).min(zz);
    }
    let q = (xx + yy + zz) / 3.0;
    let (a, b, c) = (xx - q, yy - q, zz - q);
    let p = ((a * a + b * b + c * c + 2.0 * off) / 6.0).sqrt();
    // det((A - q I) / p) / 2, within [-1, 1] but for round-off.
    let det = a * (b * c - yz * yz) - xy * (xy * c - yz * xz) + xz * (xy * yz - b * xz);
    let r = (det / (2.0 * p * p * p)).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    q + 2.0 * p * (phi + 2.0 * std::f64::consts::PI / 3.0).cos()
}

fn positive(x: f64) -> Result<(), String> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(format!("= {x}: must be a positive finite number"))
    }
}

fn nonneg(x: f64) -> Result<(), String> {
    if x.is_finite() && x >= 0.0 {
        Ok(())
    } else {
        Err(format!("= {x}: must be a finite number >= 0"))
    }
}

fn unit_interval(x: f64) -> Result<(), String> {
    if x.is_finite() && (0.0..=1.0).contains(&x) {
        Ok(())
    } else {
        Err(format!("= {x}: must lie in [0, 1]"))
    }
}

fn finite3(v: &[f64; 3]) -> Result<(), String> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(format!("= {v:?}: every component must be finite"))
    }
}

/// Refuses a quaternion that is not unit length rather than normalising it
/// silently: a typo in one component would otherwise become a different,
/// plausible-looking orientation.
fn unit_quaternion(q: &[f64; 4]) -> Result<(), String> {
    if !q.iter().all(|x| x.is_finite()) {
        return Err(format!("= {q:?}: every component must be finite"));
    }
    let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    if (norm - 1.0).abs() > 1e-6 {
        return Err(format!(
            "= {q:?}: not a unit quaternion (norm {norm}); give [w, x, y, z] with norm 1"
        ));
    }
    Ok(())
}

/// A shape's own checks: its fields present and positive. `field` names a
/// key of the shape's table.
fn check_shape(
    shape: Result<ShapeDesc, (&'static str, String)>,
    field: &dyn Fn(&str) -> String,
) -> Result<(), (String, String)> {
    match shape.map_err(|(k, m)| (field(k), m))? {
        ShapeDesc::Sphere { radius } => positive(radius).map_err(|m| (field("radius"), m)),
        ShapeDesc::Capsule {
            radius,
            half_length,
        }
        | ShapeDesc::Cylinder {
            radius,
            half_length,
        } => {
            positive(radius).map_err(|m| (field("radius"), m))?;
            positive(half_length).map_err(|m| (field("half_length"), m))
        }
        ShapeDesc::Box { half_extents } => {
            if half_extents.iter().any(|&h| positive(h).is_err()) {
                return Err((
                    field("half_extents"),
                    format!(
                        "= {half_extents:?}: each half extent must be a positive finite number"
                    ),
                ));
            }
            Ok(())
        }
        ShapeDesc::Hull { points } => super::hull::convex_hull(&points)
            .map(|_| ())
            .map_err(|e| (field("hull"), format!("has no hull: {e}"))),
    }
}
