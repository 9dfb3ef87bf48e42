//! mLCP stage: the mixed LCP of one step, reduced to a pure LCP by the Schur
//! complement of the joint block, and the recovery of velocities and joint
//! impulses from its solution (formulation.md, "To a pure LCP").
//!
//! Derivation, with `G_c = [G_n, G_f]` the contact rows and
//! `lambda = [p_n; p_f]`. The first block row of the mLCP gives
//! `nu' = nu_free + M^-1 (G_b p_b + G_c lambda)`. Substituted into the joint
//! rows `G_b^T nu' + beta psi_b / h = 0`:
//!
//! ```text
//! A_bb p_b = -(b_b + A_bc lambda),  A_xy = G_x^T M^-1 G_y,
//!                                   b_b = G_b^T nu_free + beta psi_b / h
//! ```
//!
//! `A_bb` is SPD when the joints are independent; with `A_bb = L L^T`,
//! `Y = L^-1 A_bc` and `y_b = L^-1 b_b` the contact velocities are
//!
//! ```text
//! G_c^T nu' = (A_cc - Y^T Y) lambda + (G_c^T nu_free - Y^T y_b)
//!           =  W lambda + b
//! ```
//!
//! which is `F - B D^-1 C` and `a - B D^-1 c` of the notes without ever
//! forming `D^-1`: the mass matrix is block diagonal, so only the small SPD
//! block `G_b^T M^-1 G_b` is factored. The pure LCP in `x = [p_n; p_f; s]`:
//!
//! ```text
//! [ W_nn  W_nf  0 ] [p_n]   [b_n + a_n]
//! [ W_fn  W_ff  E ] [p_f] + [b_f      ]   >= 0  _|_  x >= 0
//! [ U    -E^T   0 ] [s  ]   [0        ]
//! ```
//!
//! with `a_n` the gap (stabilisation, restitution) term of each normal row.
//!
//! Friction rows are formed on the tangent basis. Every friction direction
//! of a contact is `d_j = c_j t1 + s_j t2` (`c_j, s_j` the cosine and sine of
//! `2 pi j / n_d`), and a row is linear in its direction, so with the basis
//! rows `B = [G_b, G_n, G_t1, G_t2]` and `G_f = B C` (`C` holds `c_j, s_j`):
//!
//! ```text
//! G_f^T M^-1 G_x = C^T (B^T M^-1 G_x),   Y_f = Y_B C,   b_f = C^T b_B
//! ```
//!
//! So `W`, `Y` and `b` are formed on the `nb + nc + 2 nf` basis rows and the
//! LCP's `n_d`-row blocks are expanded from them: `(nb + nc + 2 nf)^2`
//! Delassus entries instead of `(nb + nc + n_d nf)^2` (n_d = 8, two
//! contacts and two joints: 78 instead of 300 row couplings, which were
//! 37 % of a resting reference step under perf).

mod energy;
mod recover;
mod restrict;
mod rotors;
mod schur;

/// Dense Cholesky and triangular solves for small blocks (the joint
/// block's, and the projection's in `integrate::project`).
pub use schur::{small, JOINT_CFM};

use schur::solve_lower;

use crate::constraint::applied::InvMass;
use crate::constraint::contact::Contact;
use crate::constraint::coupling::Tails;
use crate::constraint::rows::Row;
use crate::model::state::State;
use crate::model::{Model, Params};
use faer::dyn_stack::MemBuffer;
use nalgebra::Vector3;

/// Grows `b`'s capacity to `a`'s (nothing when it has that already).
fn grow_alike(a: &Vec<f64>, b: &mut Vec<f64>) {
    if b.capacity() < a.capacity() {
        b.reserve(a.capacity() - b.len());
    }
}

/// Why the reduction failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MlcpError {
    /// `G_b^T M^-1 G_b` is singular: the joint rows are dependent.
    SingularJointBlock { row: usize, pivot: f64 },
}

impl std::fmt::Display for MlcpError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MlcpError::SingularJointBlock { row, pivot } => write!(
                f,
                "singular joint block: pivot {pivot:.3e} at joint row {row} (redundant joints or a closed loop)"
            ),
        }
    }
}

/// The constant term `a_n` of a normal row, so that the row reads
/// `G_n^T nu' + a_n >= 0`.
///
/// - Separated (`psi >= 0`): `psi / h`, the body may close the gap exactly.
/// - Penetrating: `beta psi / h` removes the fraction `beta` of it.
/// - Restitution: a contact approaching faster than `v_min` whose free motion
///   would close it within the step asks for `v_n' >= -e v_n^-`, i.e.
///   `a_n = e v_n^-`; the stricter of that and the gap term wins. A contact
///   that the free motion does not close gets no bounce, or a ball would
///   bounce off thin air at the pruning margin.
pub fn normal_offset(c: &Contact, v_n_free: f64, p: &Params) -> f64 {
    let psi = c.geom.gap;
    let gap_term = if psi >= 0.0 {
        psi / p.h
    } else {
        // A compliant contact's spring sets the fraction (model.rs,
        // `Compliance`); a rigid one uses the stabilisation factor.
        p.contact_compliance.map_or(p.beta, |k| k.erp(p.h)) * psi / p.h
    };
    let closes = psi + p.h * v_n_free < 0.0;
    if c.e > 0.0 && c.v_n < -p.restitution_threshold && closes {
        gap_term.min(c.e * c.v_n)
    } else {
        gap_term
    }
}

/// A normal row whose diagonal the joints' elimination brings below this
/// fraction of its own (`W_nn - Y^T Y <= HELD W_nn`) is held by the joints:
/// its impulse moves nothing the joints do not undo, so the joints alone
/// set its gap (two spheres jointed at a point of their line of centres).
/// Such a row is never asked to separate (its `a_n` is clipped at zero, as
/// in [`Offsets::Relaxed`]) and carries no impulse: it is taken out of the
/// LCP. A penetration the joints hold cannot be removed, and asking for it
/// made the rigid LCP unsolvable or, with the row's round-off diagonal,
/// gave impulses of 1e16 N s whose leftover broke the joint and gave
/// energy (random scenes 4879, 9714). The elimination's round-off was
/// measured up to 2.7e-8 of `W_nn` (seed 5303: a sphere welded to the
/// world, another jointed to it, a joint block with a pivot near zero);
/// an impulse that needs a million times its own size to move anything
/// is held for every purpose of a step.
pub const HELD: f64 = 1e-6;

/// Which constant terms the LCP's right-hand side carries.
///
/// `Full` is the formulation of formulation.md: joint rows
/// `G_b^T nu' + beta psi_b / h = 0`, normal rows `G_n^T nu' + a_n >= 0` with
/// [`normal_offset`]'s `a_n`, negative where the row asks the contact to
/// separate (a penetration to remove, a restitution target).
///
/// `Relaxed` is the step's fallback where the `Full` LCP has no solution
/// (formulation.md, "When the rigid problem has no solution"): the joint
/// drift term is dropped (`G_b^T nu' = 0`) and every normal offset is
/// clipped at zero (`a_n <- max(a_n, 0)`: a gap may still close exactly,
/// but no row asks for a separation speed). The position errors are left
/// to the next steps' stabilisation and to the projection out of deep
/// penetration, which act on positions, not through the LCP.
///
/// Why it is always solvable: with `x = [p_n; p_f; s]`, the LCP matrix is
/// copositive (`x^T M x = lambda^T W lambda + s^T U p_n >= 0`, `W` the
/// joint-reduced Delassus matrix, positive semidefinite). Any `x` of its
/// homogeneous problem (`x >= 0, M x >= 0, x^T M x = 0`) has `W lambda = 0`,
/// so `G_c lambda + G_b p_b = 0` for some joint impulse `p_b`; then
/// `q^T x = p_b^T (beta psi_b / h) + a_n^T p_n`, which is `a_n^T p_n >= 0`
/// once the joint term is zero and `a_n >= 0`. That is the condition under
/// which Lemke's method processes a copositive LCP (Cottle, Pang and Stone,
/// Theorem 4.4.13; Anitescu and Potra 1997 use it for this very
/// formulation). The `Full` offsets break it exactly where the random
/// scenes' failures were: a corner with `mu = 1` or a pinned sphere asked
/// to separate along a direction friction locks.
///
/// And it never adds energy: with `nu' = nu_free + M^-1 G p`,
/// `K(nu') - K(nu_free) = p^T G^T nu' - 1/2 p^T G^T M^-1 G p <= p^T G^T nu'`,
/// and complementarity gives `p_b^T G_b^T nu' = 0`,
/// `p_n^T G_n^T nu' = -a_n^T p_n <= 0`, `p_f^T G_f^T nu' = -p_f^T E s <= 0`;
/// but for the motors, whose rows give at most their work
/// (`Mlcp::motor_work`). Their bounded pairs keep it solvable: the slack
/// row `F h - p+ - p-` of the homogeneous problem is `-p+ - p- >= 0`, so
/// its `x` is zero on the pairs and the argument holds as it is.
///
/// `Islands` is `Relaxed` on the rows of the islands
/// [`Mlcp::relax_islands`] marked and `Full` on the rest: a fallback is
/// taken per island. The joint block is block-diagonal by island, so the
/// other islands' `q` keeps its bits (their rows see exact zeros from the
/// relaxed rows).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Offsets {
    #[default]
    Full,
    Relaxed,
    Islands,
}

/// The step's mLCP, its reduction and its scratch space.
#[derive(Default)]
pub struct Mlcp {
    /// Rows: joints (3 each), then normal rows, then (for the iterative
    /// solver, see [`Mlcp::add_friction_rows`]) friction rows and the
    /// motors' rows.
    pub rows: Vec<Row>,
    /// Joint rows: every joint's, the rotors', then one per coupling (the last `ng`),
    /// whose tails are `tails` (`constraint::coupling`).
    pub nb: usize,
    pub ng: usize,
    /// The rotors' rows (`constraint::armature`), the `na` joint rows
    /// before the couplings'.
    pub na: usize,
    pub tails: Vec<Row>,
    /// `M^-1` times each tail ([`Row::weighted`]).
    tails_weighted: Vec<Row>,
    /// Contacts in the LCP, and how many of them have friction.
    pub nc: usize,
    pub nf: usize,
    pub nd: usize,
    /// Normal row `i` belongs to `contacts[lcp_contacts[i]]`.
    pub lcp_contacts: Vec<usize>,
    /// Joint motors (`motor.rs`), always in the problem: motor `k` drives
    /// joint `model.motors[k]`, whose first joint row is `motor_row[k]`
    /// (its island's); `motor_speed[k]` is its target (held input),
    /// `motor_cap[k]` its bound `F h` (N s or N m s).
    pub nm: usize,
    pub motor_row: Vec<usize>,
    pub motor_speed: Vec<f64>,
    pub motor_cap: Vec<f64>,
    /// Each motor's compliance `eps` (`motor::drive`; 0 when rigid), on
    /// its pair's block of the LCP matrix and its row in PGS.
    pub motor_cfm: Vec<f64>,
    /// Each motor's axis in the world at the step's start (`joint::axis`).
    pub motor_axis: Vec<Vector3<f64>>,
    /// Friction block `f` belongs to normal row `friction_of[f]`, with
    /// coefficient `mu[f]`.
    pub friction_of: Vec<usize>,
    pub mu: Vec<f64>,
    /// The basis rows `[G_b, G_n, G_t1, G_t2, G_m]`: joint rows, normal
    /// rows, `t1, t2` of each friction block, then each motor's row.
    basis: Vec<Row>,
    /// `M^-1 B`, row by row ([`Row::weighted`]); empty when matrix-free
    /// without joints (no one reads it then).
    weighted: Vec<Row>,
    /// `(cos, sin)` of each friction direction `2 pi j / n_d`.
    dirs: Vec<(f64, f64)>,
    /// `G^T nu_free` per basis row (plus `beta psi_b / h` on joint rows).
    b: Vec<f64>,
    /// Constant term of each row: a row's residual is `G_k^T nu' + offset_k`
    /// (`beta psi_b / h` on joint rows, `a_n` on normal rows, 0 on friction
    /// rows). The iterative solver works with it.
    pub offset: Vec<f64>,
    /// Each row's constraint-force mixing (`Compliance::cfm`; 0 when
    /// rigid), added to its Delassus diagonal: joint and normal rows, then
    /// friction rows (always 0).
    pub cfm: Vec<f64>,
    /// Delassus matrix of the basis rows, row-major.
    w: Vec<f64>,
    /// `A_bb`, then its Cholesky factor (lower triangle), column-major.
    chol: Vec<f64>,
    /// `Y = L^-1 A_bc` on the basis contact rows, column-major `nb x mb`,
    /// and `y_b = L^-1 b_b`.
    y: Vec<f64>,
    yb: Vec<f64>,
    /// Each LCP contact row on the basis (see [`Mlcp::fill_coeffs`]).
    coeffs: Vec<(usize, f64, usize, f64)>,
    /// Scratch on the basis contact rows: `q`, `W - Y^T Y`, `C lambda`.
    qb: Vec<f64>,
    sb: Vec<f64>,
    /// `S C`, row-major `mb x m`.
    sc: Vec<f64>,
    /// Scratch of [`Mlcp::restrict`]: kept basis contact rows, the cut `W`
    /// and `Y`.
    kept: Vec<usize>,
    new_index: Vec<usize>,
    w_cut: Vec<f64>,
    y_cut: Vec<f64>,
    zb: Vec<f64>,
    mem: Option<(usize, MemBuffer)>,
    /// The pure LCP: `lcp_m` row-major `n x n`, `lcp_q`, and its solution.
    pub lcp_m: Vec<f64>,
    pub lcp_q: Vec<f64>,
    pub z: Vec<f64>,
    /// Joint impulses (3 per joint, on body A).
    pub p_b: Vec<f64>,
    /// Per normal row, whether the joints hold it (see [`HELD`]); empty
    /// where no row is held.
    pub held: Vec<bool>,
    /// The joint block was singular (redundant joints) and was factored
    /// with a small diagonal shift.
    pub joint_regularized: bool,
    /// Impulses of every row (joint, normal, friction): the iterative
    /// solver's unknowns.
    pub lambda: Vec<f64>,
    /// `Some(matrix_free)` while the matrix part is that of the current
    /// positions and `lcp_contacts` (see [`Mlcp::matrix_for`]).
    matrix_of: Option<bool>,
    /// Per joint and normal row, whether [`Offsets::Islands`] relaxes it.
    relaxed_row: Vec<bool>,
}

/// How [`Mlcp::matrix_for`] came by the matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Assembly {
    /// Made earlier in the step (`Engine::prepare`) for the same contacts.
    Kept,
    /// Cut down from one made for more contacts.
    Restricted,
    Built,
}

/// Whether contact `c` gets friction rows: where `mu > 0`, or on every
/// touch with the skip off (a joint limit has none: it is no surface).
pub fn has_friction_rows(c: &Contact, p: &Params) -> bool {
    c.has_friction() || (!p.skips.frictionless_rows && c.limit.is_none())
}

/// The size of the pure LCP [`Mlcp::matrix_for`] would make for the
/// contacts marked `in_lcp`: `nc + nf (n_d + 1)` ([`Mlcp::lcp_size`]).
pub fn lcp_size_of(contacts: &[Contact], p: &Params) -> usize {
    contacts
        .iter()
        .filter(|c| c.in_lcp)
        .map(|c| 1 + usize::from(has_friction_rows(c, p)) * (p.friction_directions + 1))
        .sum()
}

impl Mlcp {
    /// Rows of the pure LCP before the slacks: normal, friction and the
    /// motors' pairs, `m = nc + nf n_d + 2 nm`.
    pub fn contact_rows(&self) -> usize {
        self.nc + self.nf * self.nd + 2 * self.nm
    }

    /// Unknowns of the pure LCP, `[p_n; p_f; p_m; s; s_m]`:
    /// `n = nc + nf (n_d + 1) + 3 nm`.
    pub fn lcp_size(&self) -> usize {
        self.contact_rows() + self.nf + self.nm
    }

    /// Where the motors' rows start in [`Mlcp::rows`] once the friction
    /// rows are added (the iterative solver's problem: joint, normal,
    /// friction rows, then one per motor).
    pub fn motor_rows(&self) -> usize {
        self.nb + self.nc + self.nf * self.nd
    }

    /// Where motor `k`'s pair `(p+, p-)` starts in the LCP's unknowns.
    pub fn motor_pair(&self, k: usize) -> usize {
        self.nc + self.nf * self.nd + 2 * k
    }

    /// Motor `k`'s impulse `p+ - p-` in the last answer `z`.
    pub fn motor_impulse(&self, k: usize) -> f64 {
        let at = self.motor_pair(k);
        self.z[at] - self.z[at + 1]
    }

    /// Sets the rates the motors drive to from the held inputs (per
    /// joint; read for the joints with a motor) and, for a servo, its
    /// coordinate in `state` (`motor::drive`), before [`Mlcp::rhs`].
    pub fn set_motor_speeds(&mut self, model: &Model, state: &State, speeds: &[f64]) {
        self.motor_speed.clear();
        self.motor_speed.extend(model.motors.iter().map(|&j| {
            let joint = &model.joints[j];
            match joint.motor {
                Some(m) if m.gains != crate::model::Gains::Rigid => {
                    let q = crate::constraint::joint::coordinate(joint, state).map_or(0.0, |c| c.0);
                    crate::constraint::motor::drive(
                        &m,
                        speeds[j],
                        q,
                        model.params.h,
                        joint.slide.is_none(),
                    )
                    .0
                }
                _ => speeds[j],
            }
        }));
    }

    /// Forgets the matrix part: the positions (hence the rows) changed.
    pub fn invalidate(&mut self) {
        self.matrix_of = None;
    }

    /// The contact list was listed again with more pairs (the broad phase
    /// widened, `Engine::widen`): the same contacts, at new indices. Points
    /// `lcp_contacts` at them by id (both lists ascend by id, and the new
    /// one holds every old one), so that the matrix and the answer, made
    /// for the same rows, stay valid. `old_id(ci)`: the id of the old list's
    /// contact `ci`.
    pub fn remap(&mut self, old_id: impl Fn(usize) -> usize, contacts: &[Contact]) {
        let mut at = 0;
        for ci in self.lcp_contacts.iter_mut() {
            let id = old_id(*ci);
            while contacts[at].id < id {
                at += 1;
            }
            debug_assert_eq!(contacts[at].id, id, "a widened list keeps every contact");
            *ci = at;
        }
    }

    /// Makes the matrix part for the contacts marked `in_lcp`: kept when it
    /// was made at these positions for exactly those contacts, cut down by
    /// [`Mlcp::restrict`] when they are fewer, built afresh otherwise. The
    /// right-hand side is [`Mlcp::rhs`]'s.
    ///
    /// Why: the matrix depends on the positions and the contact set, not on
    /// the inputs, so the lockstep server makes it while the controllers
    /// compute (`Engine::prepare`, on the contacts its predicted free
    /// velocity selects); the step then only checks that the inputs selected
    /// the same contacts. Every number is computed by the same operations on
    /// the same rows whichever way it was made, so the step's bits do not
    /// depend on it.
    pub fn matrix_for(
        &mut self,
        model: &Model,
        state: &State,
        contacts: &[Contact],
        minv: &[InvMass],
        matrix_free: bool,
    ) -> Result<Assembly, MlcpError> {
        if self.matrix_of == Some(matrix_free) {
            let selected = contacts.iter().filter(|c| c.in_lcp).count();
            let kept = self
                .lcp_contacts
                .iter()
                .filter(|&&ci| contacts.get(ci).is_some_and(|c| c.in_lcp))
                .count();
            if kept == selected {
                if kept == self.lcp_contacts.len() {
                    return Ok(Assembly::Kept);
                }
                if !matrix_free && self.restrict(contacts) {
                    return Ok(Assembly::Restricted);
                }
            }
        }
        self.build_matrix(model, state, contacts, minv, matrix_free)?;
        Ok(Assembly::Built)
    }

    /// The rows, the Delassus matrix, the joint factor and (unless
    /// `matrix_free`) the reduced LCP's matrix for the contacts marked
    /// `in_lcp`: everything but the right-hand side.
    fn build_matrix(
        &mut self,
        model: &Model,
        state: &State,
        contacts: &[Contact],
        minv: &[InvMass],
        matrix_free: bool,
    ) -> Result<(), MlcpError> {
        self.matrix_of = None;
        let p = &model.params;
        let nd = p.friction_directions;
        if self.dirs.len() != nd {
            self.dirs.clear();
            self.dirs
                .extend((0..nd).map(|j| crate::constraint::contact::direction_coefficients(j, nd)));
        }
        self.rows.clear();
        self.basis.clear();
        self.offset.clear();
        self.lcp_contacts.clear();
        self.friction_of.clear();
        self.mu.clear();

        // Joint rows (joint.rs): the anchors, then the rotation a hinge or
        // a fixed joint holds.
        let factor = p.joint_compliance.map_or(p.beta, |k| k.erp(p.h));
        for joint in &model.joints {
            crate::constraint::joint::push_rows(
                joint,
                state,
                factor,
                p.h,
                &mut self.rows,
                &mut self.offset,
            );
        }
        // The rotors' rows (armature.rs), then the couplings: their heads
        // are joint rows, their tails beside.
        let before = self.rows.len();
        for joint in &model.joints {
            crate::constraint::armature::push_rows(joint, state, &mut self.rows, &mut self.offset);
        }
        self.na = self.rows.len() - before;
        self.tails.clear();
        for c in &model.couplings {
            let (head, tail, offset) =
                crate::constraint::coupling::rows(c, &model.joints, state, factor, p.h);
            self.rows.push(head);
            self.tails.push(tail);
            self.offset.push(offset);
        }
        self.ng = self.tails.len();
        self.nb = self.rows.len();
        self.tails_weighted.clear();
        self.tails_weighted
            .extend(self.tails.iter().map(|row| row.weighted(minv)));

        // Normal rows, then friction rows where mu > 0.
        for (ci, c) in contacts.iter().enumerate().filter(|(_, c)| c.in_lcp) {
            let row = Row::contact(c, c.geom.normal);
            self.rows.push(row);
            self.lcp_contacts.push(ci);
        }
        self.nc = self.lcp_contacts.len();
        // Each row's compliance (model.rs, `Compliance`): joint rows, then
        // normal rows; friction rows stay rigid.
        self.cfm.clear();
        let joint_cfm = p.joint_compliance.map_or(0.0, |k| k.cfm(p.h));
        let contact_cfm = p.contact_compliance.map_or(0.0, |k| k.cfm(p.h));
        self.cfm.resize(self.nb, joint_cfm);
        let mut k = self.nb - self.ng - self.na;
        for joint in &model.joints {
            for _ in 0..joint.armature_rows() {
                self.cfm[k] = crate::constraint::armature::compliance(joint);
                k += 1;
            }
        }
        self.cfm.resize(self.nb + self.nc, contact_cfm);
        self.basis.extend_from_slice(&self.rows);
        for i in 0..self.nc {
            let c = &contacts[self.lcp_contacts[i]];
            if has_friction_rows(c, p) {
                for t in [c.t1, c.t2] {
                    self.basis.push(Row::contact(c, t));
                }
                self.friction_of.push(i);
                self.mu.push(c.mu);
            }
        }
        self.nf = self.friction_of.len();
        self.nd = nd;
        // The motors' rows, last in the basis (motor.rs).
        self.motor_row.clear();
        self.motor_cap.clear();
        self.motor_cfm.clear();
        self.motor_axis.clear();
        for &j in &model.motors {
            let joint = &model.joints[j];
            let (Some(row), Some(motor)) = (
                crate::constraint::motor::rate_row(joint, state),
                joint.motor,
            ) else {
                unreachable!("the scene gives motors to hinges and sliders only")
            };
            self.basis.push(row);
            self.motor_axis
                .push(crate::constraint::joint::axis(joint, state).unwrap_or_else(Vector3::zeros));
            self.motor_row.push(model.joint_start[j]);
            self.motor_cap.push(motor.max_effort * p.h);
            self.motor_cfm
                .push(crate::constraint::motor::compliance(&motor, p.h));
        }
        self.nm = self.motor_row.len();
        self.offset.resize(self.rows.len(), 0.0);
        if matrix_free {
            self.add_friction_rows(contacts);
        }

        // Delassus matrix of the basis rows, B^T M^-1 B (symmetric). The
        // iterative solver (`matrix_free`) needs only the joint rows' part,
        // for the joints' response in the free normal speeds; the contact
        // block is Lemke's alone. Row-major, so the joint rows' part is the
        // first nb rows.
        let r = self.basis.len();
        let upto = if matrix_free { self.nb } else { r };
        self.weighted.clear();
        // Matrix-free without joints nothing reads them: `recover` and
        // `kinetic_change_by_island` are Lemke's (fallback.rs), the iterative solver
        // weights its own rows (pgs.rs). Measured on the 4,000 pile (10
        // layers, steps 101-200, alternated twice): the assembly's median
        // 2.66 and 2.74 ms against 2.83 and 3.16 ms.
        if upto > 0 {
            self.weighted
                .extend(self.basis.iter().map(|row| row.weighted(minv)));
        }
        self.w.clear();
        self.w.resize(upto * r, 0.0);
        for k in 0..upto {
            for l in k..r {
                let v = self.basis[k].dot(&self.weighted[l]);
                self.w[k * r + l] = v;
                if l < upto {
                    self.w[l * r + k] = v;
                }
            }
        }
        // A coupling's row and column again, with its tail on either side.
        for k in self.nb - self.ng..self.nb {
            for l in 0..r {
                let v = self.wide_dot(k, l);
                self.w[k * r + l] = v;
                if l < upto {
                    self.w[l * r + k] = v;
                }
            }
        }

        self.fill_coeffs();
        self.reduce_joints()?;
        // `restrict` swaps each of these with its cut: the two must grow
        // together, or which of them is the larger depends on how many
        // cuts came before, and a second pass over the same run (its
        // cuts in another parity) reallocated `y` (limits.toml, found by
        // tests/tests/no_allocation.rs).
        grow_alike(&self.w, &mut self.w_cut);
        grow_alike(&self.y, &mut self.y_cut);
        if matrix_free {
            self.lcp_m.clear();
            self.mark_held_matrix_free();
        } else {
            self.form_matrix();
        }
        self.matrix_of = Some(matrix_free);
        Ok(())
    }

    /// The right-hand side for the free velocity `nu_free`, on the matrix
    /// part made by [`Mlcp::matrix_for`]: `b` (`G^T nu_free`, plus
    /// `beta psi_b / h` on the joint rows), `y_b = L^-1 b_b` and the LCP's
    /// `q` with the normal offsets; with [`Offsets::Relaxed`], the offsets
    /// that ask for motion are left out (see there).
    pub fn rhs(&mut self, nu_free: &[f64], contacts: &[Contact], p: &Params, offsets: Offsets) {
        let nb = self.nb;
        self.b.clear();
        let tails = Tails {
            first: nb - self.ng,
            rows: &self.tails,
        };
        for (k, row) in self.basis.iter().enumerate() {
            let v = tails.velocity(k, row, nu_free);
            let drift = k < nb && !self.relaxes(offsets, k);
            self.b.push(if drift { v + self.offset[k] } else { v });
        }
        self.yb.clear();
        self.yb.extend_from_slice(&self.b[..nb]);
        solve_lower(&self.chol, nb, &mut self.yb);
        self.form_rhs(contacts, p, offsets);
    }

    /// The couplings' tails (`constraint::coupling`).
    pub fn tails(&self) -> Tails<'_> {
        Tails {
            first: self.nb - self.ng,
            rows: &self.tails,
        }
    }

    /// The Delassus entry of basis rows `k` and `l`, each with its tail
    /// if it has one: `(B_k + T_k)^T M^-1 (B_l + T_l)`.
    fn wide_dot(&self, k: usize, l: usize) -> f64 {
        let (tails, weighted) = (
            self.tails(),
            Tails {
                first: self.nb - self.ng,
                rows: &self.tails_weighted,
            },
        );
        let (bk, wl) = (&self.basis[k], &self.weighted[l]);
        let mut v = bk.dot(wl);
        if let Some(t) = tails.get(k) {
            v += t.dot(wl);
        }
        if let Some(tw) = weighted.get(l) {
            v += bk.dot(tw);
            if let Some(t) = tails.get(k) {
                v += t.dot(tw);
            }
        }
        v
    }

    /// `nu += M^-1 G_k impulse` for joint row `k`, its tail included.
    pub fn add_joint_impulse(&self, k: usize, impulse: f64, nu: &mut [f64]) {
        self.weighted[k].add_to(impulse, nu);
        if let Some(i) = k.checked_sub(self.nb - self.ng) {
            if let Some(t) = self.tails_weighted.get(i) {
                t.add_to(impulse, nu);
            }
        }
    }

    /// Marks the joint and normal rows of the islands `relax` flags (by
    /// `groups`, the step's islands) for [`Offsets::Islands`].
    pub fn relax_islands(&mut self, groups: &crate::solver::island::Groups, relax: &[bool]) {
        self.relaxed_row.clear();
        self.relaxed_row
            .extend((0..self.nb + self.nc).map(|k| relax[groups.island_of_row(k)]));
    }

    /// The rotors' rows (`constraint::armature`) in the joint block.
    pub fn armature(&self) -> std::ops::Range<usize> {
        let end = self.nb - self.ng;
        end - self.na..end
    }

    /// Whether row `k`'s constant term is a joint's drift term: a joint
    /// row's but a rotor's, whose constant is its rate (no drift).
    pub fn drifts(&self, k: usize) -> bool {
        k < self.nb && !self.armature().contains(&k)
    }

    /// Whether joint or normal row `k` is relaxed under `offsets`.
    fn relaxes(&self, offsets: Offsets, k: usize) -> bool {
        if self.armature().contains(&k) {
            return false;
        }
        match offsets {
            Offsets::Full => false,
            Offsets::Relaxed => true,
            Offsets::Islands => self.relaxed_row[k],
        }
    }

    /// Fills [`Mlcp::coeffs`]: contact row `i` of the LCP (normal rows,
    /// then the friction blocks) as `c1 B[k1] + c2 B[k2]` over the basis
    /// contact rows (indices past the joint rows); a normal row is itself
    /// (`k2 = k1`, `c2 = 0`). A table, so that the O(m^2) expansion does no
    /// index arithmetic.
    fn fill_coeffs(&mut self) {
        self.coeffs.clear();
        self.coeffs.extend((0..self.nc).map(|i| (i, 1.0, i, 0.0)));
        for f in 0..self.nf {
            let k = self.nc + 2 * f;
            self.coeffs
                .extend(self.dirs.iter().map(|&(cs, sn)| (k, cs, k + 1, sn)));
        }
        // A motor's pair: its row and the row negated.
        for k in 0..self.nm {
            let b = self.nc + 2 * self.nf + k;
            self.coeffs.extend([(b, 1.0, b, 0.0), (b, -1.0, b, 0.0)]);
        }
    }

    /// `(cos, sin)` of friction direction `j` as the rows use it.
    pub fn direction(&self, j: usize) -> (f64, f64) {
        self.dirs[j]
    }

    /// [`Mlcp::held`] without the formed matrix: the reduced diagonal
    /// `W_nn - |y_n|^2` from the normal row and its column of `Y`, as
    /// `form_matrix` has it in `sb`.
    fn mark_held_matrix_free(&mut self) {
        let nb = self.nb;
        self.held.clear();
        if nb == 0 {
            return;
        }
        for i in 0..self.nc {
            let unreduced = self.basis[nb + i].dot(&self.weighted[nb + i]);
            let yi = &self.y[i * nb..(i + 1) * nb];
            let reduced = unreduced - yi.iter().map(|a| a * a).sum::<f64>();
            self.held.push(reduced <= HELD * unreduced);
        }
    }

    /// The largest diagonal entry of the contact rows' Delassus matrix
    /// before the joints are eliminated (m/s per N s; 0 when not formed):
    /// the scale of a contact row whose reduced row the joints make zero.
    pub fn contact_scale(&self) -> f64 {
        let r = self.basis.len();
        if self.w.len() < r * r {
            return 0.0;
        }
        (self.nb..r).fold(0.0f64, |a, i| a.max(self.w[i * r + i]))
    }
}
