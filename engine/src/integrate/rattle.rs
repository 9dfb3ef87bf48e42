//! RATTLE (issue 48, point 2): the step of an island with joints and no
//! contact, limit or motor, with positions and velocities held on the
//! joints to round-off, symplectic and of second order; composed to fourth
//! order with Suzuki's five stages (`Integrator::Rattle4`).
//!
//! One step of `tau` (Hairer, Lubich and Wanner, Geometric Numerical
//! Integration, VII.1.4), the bodies' momenta `p = m v` and world angular
//! momenta `L = J w`, the joints' rows `G(q)` and position errors `psi(q)`
//! (`constraint::joint::push_rows`), the applied forces `F(q)`
//! (gravity, body forces, joint efforts):
//!
//! ```text
//!   p+ = p + tau/2 F(q) + G(q)^T P        (a kick; P unknown)
//!   q' = flow of the kinetic energy over tau from q with p+
//!   psi(q') = 0                            (solved for P: Newton)
//!   p' = p+ + tau/2 F(q') + G(q')^T Q      (Q: G(q') M(q')^-1 p' = 0)
//! ```
//!
//! The kinetic energy's flow moves each body's centre by `tau v` and turns
//! it as a free rigid body with angular momentum `L`: exactly for a body
//! with two or three equal principal moments (a sphere, a capsule, a
//! cylinder), else by the symmetric splitting of Dullweber, Leimkuhler and
//! McLachlan (1997) into rotations about the principal axes (`x/2, y/2, z,
//! y/2, x/2`), each exact, which keeps the step symplectic and
//! time-reversible. No gyroscopic term appears: the
//! flow holds `L` and turns the body.
//!
//! The Newton iteration on `P` uses the Delassus matrix at the step's start
//! times `tau` as its Jacobian (SHAKE's), factored once; it stops at
//! `TOLERANCE` of every row's error. An island whose iteration does not
//! converge (a step too large for the motion) is left to the velocity-level
//! step, and the engine counts it.

use super::skyline::Skyline;
use crate::constraint::applied::{self, bounded, effort_on, Inputs, InvMass};
use crate::constraint::rows::Row;
use crate::model::state::{BodyState, State};
use crate::model::Model;
use cosim_shared::Integrator;
use nalgebra::{Matrix3, SymmetricEigen, UnitQuaternion, Vector3};

/// The joint error (m, or rad on a turning row) at which the position
/// iteration stops.
pub const TOLERANCE: f64 = 1e-14;

/// Newton steps from the last step's impulses, then as many from zero,
/// before an island is left to the velocity-level step.
const MAX_ITERATIONS: usize = 50;

/// Suzuki's fourth-order composition of a symmetric second-order step:
/// `g1 = g2 = g4 = g5 = 1 / (4 - 4^(1/3))`, `g3 = 1 - 4 g1`.
fn suzuki() -> [f64; 5] {
    let g = 1.0 / (4.0 - 4f64.powf(1.0 / 3.0));
    [g, g, 1.0 - 4.0 * g, g, g]
}

/// Why an island was left to the velocity-level step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RattleError {
    /// The position iteration did not bring the joints' errors under
    /// [`TOLERANCE`]: the largest left (m or rad).
    NotConverged { error: f64 },
    /// The joint block was singular (redundant joints): its pivot row.
    Singular { row: usize },
}

/// A body's principal moments and axes (the columns of `axes`, in the
/// body frame, a proper rotation).
#[derive(Debug, Clone, Copy)]
struct Principal {
    moments: Vector3<f64>,
    axes: UnitQuaternion<f64>,
    /// Which moments are equal (to 1e-12 of the largest).
    shape: Top,
}

/// A rigid body's kind of free rotation.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Top {
    /// Three equal moments (a sphere, a cube): a rotation about `L`.
    Spherical,
    /// Two equal moments, the third about principal axis `k` (a capsule, a
    /// cylinder): a rotation about `L` and one about the body's axis `k`,
    /// which commute, so the flow is exact.
    Symmetric(usize),
    /// Three different moments: split about the principal axes.
    Asymmetric,
}

impl Principal {
    fn of(inertia: &Matrix3<f64>) -> Principal {
        let e = SymmetricEigen::new(*inertia);
        let mut axes = e.eigenvectors;
        if axes.determinant() < 0.0 {
            axes.set_column(2, &(-axes.column(2)));
        }
        let m = e.eigenvalues;
        let equal = |a: usize, b: usize| (m[a] - m[b]).abs() <= 1e-12 * m.max().abs();
        let shape = match (equal(0, 1), equal(1, 2), equal(0, 2)) {
            (true, true, _) => Top::Spherical,
            (true, false, _) => Top::Symmetric(2),
            (false, true, _) => Top::Symmetric(0),
            (false, false, true) => Top::Symmetric(1),
            _ => Top::Asymmetric,
        };
        Principal {
            moments: m,
            axes: UnitQuaternion::from_matrix(&axes),
            shape,
        }
    }

    /// The free rigid body's flow over `tau` from orientation `q` with
    /// world angular momentum `l` (which it keeps).
    fn turn(&self, q: UnitQuaternion<f64>, l: Vector3<f64>, tau: f64) -> UnitQuaternion<f64> {
        let k = match self.shape {
            Top::Spherical => {
                return UnitQuaternion::from_scaled_axis(l * (tau / self.moments[0])) * q;
            }
            Top::Symmetric(k) => k,
            Top::Asymmetric => return self.split(q, l, tau),
        };
        // `H = |pi|^2 / 2 I + pi_k^2 (1 / I_k - 1 / I) / 2`, `I` the equal
        // moment: the first part turns the body about `l` (in the world),
        // the second about its axis `k` (in the body), and the two commute.
        let i = self.moments[(k + 1) % 3];
        let r = q * self.axes;
        let pi_k = r.inverse_transform_vector(&l)[k];
        let spin = tau * pi_k * (1.0 / self.moments[k] - 1.0 / i);
        let about = Vector3::ith_axis(k);
        let r = UnitQuaternion::from_scaled_axis(l * (tau / i))
            * r
            * UnitQuaternion::from_axis_angle(&about, spin);
        r * self.axes.inverse()
    }

    /// The asymmetric top's flow split about its principal axes (`x/2,
    /// y/2, z, y/2, x/2`), each part exact: symplectic, time-reversible,
    /// second order.
    fn split(&self, q: UnitQuaternion<f64>, l: Vector3<f64>, tau: f64) -> UnitQuaternion<f64> {
        // In the principal frame: `R = q axes`, `pi = R^T l`.
        let mut r = q * self.axes;
        let mut pi = r.inverse_transform_vector(&l);
        for (k, part) in [(0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)] {
            let theta = part * tau * pi[k] / self.moments[k];
            let about = Vector3::ith_axis(k);
            r *= UnitQuaternion::from_axis_angle(&about, theta);
            pi = UnitQuaternion::from_axis_angle(&about, -theta) * pi;
        }
        r * self.axes.inverse()
    }
}

/// Scratch of the RATTLE step, kept from step to step.
#[derive(Default)]
pub struct Rattle {
    principal: Vec<Principal>,
    /// A state whose bodies are the island's trial poses (the joints'
    /// rows read a `State`); allocated once.
    trial: Option<State>,
    /// The joints' rows and errors at the substep's start and at the
    /// trial poses.
    rows0: Vec<Row>,
    psi0: Vec<f64>,
    rows: Vec<Row>,
    psi: Vec<f64>,
    /// The joint block, factored within its envelope.
    block: Skyline,
    impulse: Vec<f64>,
    delta: Vec<f64>,
    /// Per body of the model (the island's are read): the substep's start
    /// pose, its momenta with the half step's applied impulses, the applied
    /// force and torque, the momenta after the first kick, and the world
    /// inverse masses.
    x0: Vec<Vector3<f64>>,
    q0: Vec<UnitQuaternion<f64>>,
    p0: Vec<Vector3<f64>>,
    l0: Vec<Vector3<f64>>,
    force: Vec<Vector3<f64>>,
    torque: Vec<Vector3<f64>>,
    p_half: Vec<Vector3<f64>>,
    l_half: Vec<Vector3<f64>>,
    minv: Vec<InvMass>,
    nu: Vec<f64>,
    /// The last step's impulses `P` of each stage on each joint row (the
    /// model's joint rows, `Model::joint_start`, per stage): the next
    /// step's first guess, which the motion changes by O(h) only.
    warm: Vec<f64>,
    /// The Newton iterations of the last [`step`].
    pub iterations: usize,
    /// `block` holds the factor of the Delassus matrix at the trial poses
    /// (the last substep's velocity projection: the next substep's
    /// Jacobian, at the same poses).
    factored: bool,
}

/// An island for [`step`]: its bodies and its joints (indices into the
/// model's).
#[derive(Clone, Copy)]
pub struct Island<'a> {
    pub bodies: &'a [u32],
    pub joints: &'a [u32],
}

/// Steps `island` from `state` by the model's `h` with `order`'s scheme
/// (`Integrator::Rattle` or `Rattle4`) into `out` (one per island body, in
/// its order). `inputs`' body impulses act in the first kick.
pub fn step(
    model: &Model,
    state: &State,
    inputs: &Inputs,
    island: Island,
    order: Integrator,
    ws: &mut Rattle,
    out: &mut Vec<BodyState>,
) -> Result<(), RattleError> {
    let n = model.bodies.len();
    if ws.principal.len() != n {
        ws.principal = model
            .bodies
            .iter()
            .map(|b| Principal::of(&b.inertia))
            .collect();
    }
    let trial = match &mut ws.trial {
        Some(t) if t.bodies.len() == state.bodies.len() => t,
        slot => slot.insert(state.clone()),
    };
    for &i in island.bodies {
        trial.bodies[i as usize] = state.bodies[i as usize];
    }
    for v in [
        &mut ws.x0,
        &mut ws.p0,
        &mut ws.l0,
        &mut ws.force,
        &mut ws.torque,
        &mut ws.p_half,
        &mut ws.l_half,
    ] {
        v.resize(n, Vector3::zeros());
    }
    ws.q0.resize(n, UnitQuaternion::identity());
    ws.minv.resize(
        n,
        InvMass {
            inv_m: 0.0,
            inv_i: Matrix3::zeros(),
        },
    );
    ws.nu.resize(6 * n, 0.0);
    let h = model.params.h;
    let stages: &[f64] = match order {
        Integrator::Rattle4 => &suzuki(),
        _ => &[1.0],
    };
    let rows = model.joint_start[model.joints.len()];
    ws.warm.resize(rows * stages.len(), 0.0);
    ws.iterations = 0;
    ws.factored = false;
    for (k, &g) in stages.iter().enumerate() {
        substep(model, inputs, island, g * h, k, ws)?;
    }
    out.clear();
    let trial = ws.trial.as_ref().expect("set above");
    out.extend(island.bodies.iter().map(|&i| trial.bodies[i as usize]));
    Ok(())
}

/// Each island body's applied force and torque (N, N m) at the trial
/// poses: gravity, its body force, its joints' held efforts (a slider's
/// at B's anchor, on both sides).
fn applied(model: &Model, inputs: &Inputs, island: Island, ws: &mut Rattle) {
    let trial = ws.trial.as_ref().expect("set by step");
    for &i in island.bodies {
        let b = &model.bodies[i as usize];
        ws.force[i as usize] = model.params.gravity * b.mass + b.force;
        ws.torque[i as usize] = Vector3::zeros();
    }
    for &j in island.joints {
        let joint = &model.joints[j as usize];
        let effort = bounded(joint, trial, &inputs.joint_torque[j as usize]).0;
        effort_on(joint, trial, effort, |i, force, torque| {
            ws.force[i] += force;
            ws.torque[i] += torque;
        });
    }
}

/// The joint rows and errors of the island at `trial`'s poses.
fn joint_rows(
    model: &Model,
    island: Island,
    trial: &State,
    rows: &mut Vec<Row>,
    psi: &mut Vec<f64>,
) {
    let joints = island.joints.iter().map(|&j| &model.joints[j as usize]);
    crate::constraint::joint::position_rows(joints, trial, rows, psi);
}

/// The island bodies' world inverse masses at the trial poses.
fn inverse_masses(model: &Model, island: Island, ws: &mut Rattle) {
    let trial = ws.trial.as_ref().expect("set by step");
    applied::inverse_masses(model, trial, Some(island.bodies), &mut ws.minv);
}

/// One RATTLE step of `tau` on the trial poses (see the module notes).
fn substep(
    model: &Model,
    inputs: &Inputs,
    island: Island,
    tau: f64,
    stage: usize,
    ws: &mut Rattle,
) -> Result<(), RattleError> {
    let first = stage == 0;
    // The start: poses, momenta with the first half step's applied
    // impulses, world inverse masses, rows.
    inverse_masses(model, island, ws);
    applied(model, inputs, island, ws);
    {
        let trial = ws.trial.as_ref().expect("set by step");
        for &i in island.bodies {
            let (i, b, s) = (
                i as usize,
                &model.bodies[i as usize],
                &trial.bodies[i as usize],
            );
            let r = s.q.to_rotation_matrix();
            let j_world = r.matrix() * b.inertia * r.matrix().transpose();
            ws.x0[i] = s.x;
            ws.q0[i] = s.q;
            ws.p0[i] = s.v * b.mass + ws.force[i] * (0.5 * tau);
            ws.l0[i] = j_world * s.w + ws.torque[i] * (0.5 * tau);
            if first {
                // A held body impulse acts once, in the step's first kick.
                let (lin, ang) = inputs.body_impulse[i];
                ws.p0[i] += lin;
                ws.l0[i] += ang;
            }
        }
        joint_rows(model, island, trial, &mut ws.rows0, &mut ws.psi0);
    }
    // SHAKE's Jacobian: tau G M^-1 G^T at the start, factored once (the
    // Delassus matrix alone: a stage of Suzuki's composition has tau < 0);
    // the last substep's projection factored it at these poses already.
    if !std::mem::take(&mut ws.factored) {
        ws.block
            .factor(&ws.rows0, &ws.minv)
            .map_err(|row| RattleError::Singular { row })?;
    }
    // The first guess: this stage's impulses of the last step.
    let rows = model.joint_start[model.joints.len()];
    ws.impulse.clear();
    for &j in island.joints {
        let (a, b) = (
            model.joint_start[j as usize],
            model.joint_start[j as usize + 1],
        );
        ws.impulse
            .extend_from_slice(&ws.warm[stage * rows + a..stage * rows + b]);
    }
    let mut error = f64::INFINITY;
    for k in 0..2 * MAX_ITERATIONS {
        if k == MAX_ITERATIONS {
            // The last step's guess led astray: from zero impulses.
            ws.impulse.fill(0.0);
        }
        ws.iterations += 1;
        drift(model, island, tau, ws);
        let trial = ws.trial.as_ref().expect("set by step");
        joint_rows(model, island, trial, &mut ws.rows, &mut ws.psi);
        error = ws.psi.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        if error <= TOLERANCE {
            break;
        }
        ws.delta.clear();
        ws.delta.extend(ws.psi.iter().map(|x| -x / tau));
        ws.block.solve(&mut ws.delta);
        for (p, d) in ws.impulse.iter_mut().zip(&ws.delta) {
            *p += d;
        }
    }
    if error.is_nan() || error > TOLERANCE {
        // Not a guess for the next step.
        for &j in island.joints {
            let (a, b) = (
                model.joint_start[j as usize],
                model.joint_start[j as usize + 1],
            );
            ws.warm[stage * rows + a..stage * rows + b].fill(0.0);
        }
        return Err(RattleError::NotConverged { error });
    }
    let mut at = 0;
    for &j in island.joints {
        let (a, b) = (
            model.joint_start[j as usize],
            model.joint_start[j as usize + 1],
        );
        ws.warm[stage * rows + a..stage * rows + b].copy_from_slice(&ws.impulse[at..at + b - a]);
        at += b - a;
    }
    // The second kick at the new poses, then the velocities projected
    // onto the joints' tangent space: G(q') M(q')^-1 p' = 0.
    inverse_masses(model, island, ws);
    applied(model, inputs, island, ws);
    let trial = ws.trial.as_mut().expect("set by step");
    for &i in island.bodies {
        let (i, b) = (i as usize, &model.bodies[i as usize]);
        let s = &mut trial.bodies[i];
        s.v = (ws.p_half[i] + ws.force[i] * (0.5 * tau)) * b.inv_mass;
        s.w = ws.minv[i].inv_i * (ws.l_half[i] + ws.torque[i] * (0.5 * tau));
        ws.nu[6 * i..6 * i + 3].copy_from_slice(s.v.as_slice());
        ws.nu[6 * i + 3..6 * i + 6].copy_from_slice(s.w.as_slice());
    }
    ws.block
        .factor(&ws.rows, &ws.minv)
        .map_err(|row| RattleError::Singular { row })?;
    ws.factored = true;
    ws.delta.clear();
    ws.delta.extend(ws.rows.iter().map(|r| -r.velocity(&ws.nu)));
    ws.block.solve(&mut ws.delta);
    for (row, &q) in ws.rows.iter().zip(&ws.delta) {
        row.apply(q, &ws.minv, &mut ws.nu);
    }
    for &i in island.bodies {
        let (i, s) = (i as usize, &mut trial.bodies[i as usize]);
        s.v = Vector3::new(ws.nu[6 * i], ws.nu[6 * i + 1], ws.nu[6 * i + 2]);
        s.w = Vector3::new(ws.nu[6 * i + 3], ws.nu[6 * i + 4], ws.nu[6 * i + 5]);
    }
    Ok(())
}

/// The first kick with the trial impulses `ws.impulse` on the start's
/// rows, and the kinetic energy's flow over `tau` from the start's poses
/// into the trial poses.
fn drift(model: &Model, island: Island, tau: f64, ws: &mut Rattle) {
    for &i in island.bodies {
        ws.p_half[i as usize] = ws.p0[i as usize];
        ws.l_half[i as usize] = ws.l0[i as usize];
    }
    for (row, &p) in ws.rows0.iter().zip(&ws.impulse) {
        for j in [row.a, row.b].into_iter().flatten() {
            ws.p_half[j.body] += j.lin * p;
            ws.l_half[j.body] += j.ang * p;
        }
    }
    let trial = ws.trial.as_mut().expect("set by step");
    for &i in island.bodies {
        let (i, b) = (i as usize, &model.bodies[i as usize]);
        let s = &mut trial.bodies[i];
        s.x = ws.x0[i] + ws.p_half[i] * (tau * b.inv_mass);
        s.q = ws.principal[i].turn(ws.q0[i], ws.l_half[i], tau);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The symmetric top's exact flow against its split flow in many small
    /// steps (second order: 1e-3 of the step, 1e-6 of the error).
    #[test]
    fn a_symmetric_top_turns_as_its_split_flow_converges() {
        let inertia = Matrix3::from_diagonal(&Vector3::new(0.3, 0.3, 0.1));
        let top = Principal::of(&inertia);
        assert_eq!(top.shape, Top::Symmetric(2));
        let q = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1);
        let l = Vector3::new(0.4, -0.7, 0.9);
        let exact = top.turn(q, l, 0.5);
        let mut split = q;
        for _ in 0..1000 {
            split = top.split(split, l, 0.5 / 1000.0);
        }
        assert!(exact.angle_to(&split) < 1e-6, "{}", exact.angle_to(&split));
        // It keeps L: the world angular velocity J^-1 L is the same
        // function of the new orientation that conserves energy.
        let energy = |q: UnitQuaternion<f64>| {
            let r = q.to_rotation_matrix();
            let j = r.matrix() * inertia * r.matrix().transpose();
            0.5 * l.dot(&(j.try_inverse().unwrap() * l))
        };
        assert!((energy(exact) - energy(q)).abs() < 1e-14 * energy(q));
    }
}
