//! The solve stage: applied impulses and the contacts they select, the
//! mLCP, the solver by island (Lemke, PGS or both under `auto`, each with
//! its fallback ladder), the recovered velocities, and the re-solves when
//! the new velocities close a contact the pruning left out.

use super::workspace::Speeds;
use super::{Clock, Engine};
use crate::measure::report::{StepError, StepReport};
use crate::solver::guess::carry_guess;
use crate::solver::island;
use crate::solver::mlcp::{Assembly, Offsets};
use crate::solver::pgs::Stop;
use crate::solver::{
    fallback, iterative, matrix_free, prune, LemkeError, PgsParams, AUTO_ESCAPE_SIZE, AUTO_PGS_SIZE,
};
use cosim_shared::SolverChoice;

impl Engine {
    /// Applied impulses, pruning, mLCP, solver and recovery, repeated while
    /// the velocity check adds left-out contacts. Leaves `nu'` in `ws.nu`.
    pub(super) fn solve(
        &mut self,
        report: &mut StepReport,
        clock: &mut Clock,
    ) -> Result<(), StepError> {
        let model = &self.model;
        let ws = &mut self.ws;
        ws.select(model, &self.state, &self.inputs);
        ws.drifted.clear();
        ws.drifted.resize(model.bodies.len(), false);
        let p = &model.params;
        let mut canonical = false;
        let mut pgs_settled;
        // The last solve was PGS's (whole or by island).
        let mut pgs_solved;
        // PGS's cap bounds the step's sweeps over all its solves: each
        // re-solve gets what the earlier ones left. Measured without it: a
        // settling 10,000 pile re-solved 35 times in one step, each solve
        // to the cap (172,618 sweeps, 396 s), because every unconverged
        // answer closes a few more of the contacts pruning left out.
        let mut sweeps_left = self.pgs_params.max_iterations;
        // The next solve starts from the last one's answer
        // (`iterative::Scratch::keep_attempt`).
        let mut from_attempt = false;
        // The last solve's answer is of a fallback formulation.
        let mut relaxed = false;
        loop {
            {
                let _span = tracing::trace_span!("assemble").entered();
                // Kept from `prepare` when these inputs select the same
                // contacts; cut down for the canonical re-solve.
                let how = ws
                    .mlcp
                    .matrix_for(
                        model,
                        &self.state,
                        &ws.contacts,
                        &ws.minv,
                        matrix_free(p, &ws.contacts),
                    )
                    .map_err(StepError::Mlcp)?;
                report.early_matrix |= report.resolves == 0 && !canonical && how != Assembly::Built;
                ws.mlcp
                    .set_motor_speeds(model, &self.state, &self.inputs.motor_speed);
                ws.mlcp.rhs(&ws.nu_free, &ws.contacts, p, Offsets::Full);
                report.regularized += usize::from(ws.mlcp.joint_regularized);
            }
            // Pruning, the velocity checks and the cuts count as assembly.
            clock.timings.assemble += clock.lap.lap();
            {
                let _span = tracing::trace_span!("solve").entered();
                let m = &mut ws.mlcp;
                ws.summary = island::group(
                    &mut ws.islands,
                    model.bodies.len(),
                    &m.rows[..m.nb + m.nc],
                    m.tails(),
                    &mut ws.groups,
                );
                let step = fallback::Step {
                    nu_free: &ws.nu_free,
                    contacts: &ws.contacts,
                    params: p,
                    minv: &ws.minv,
                    awake: ws.awake.bodies(),
                    groups: &ws.groups,
                    escape: p.solver == SolverChoice::Auto && m.lcp_size() > AUTO_ESCAPE_SIZE,
                };
                let n = m.lcp_size();
                m.z.clear();
                m.z.resize(n, 0.0);
                report.lcp_size = report.lcp_size.max(n);
                report.contacts_in_lcp = report.contacts_in_lcp.max(m.nc);
                let mut use_pgs = match p.solver {
                    SolverChoice::Lemke => false,
                    SolverChoice::Pgs => true,
                    SolverChoice::Auto => n > AUTO_PGS_SIZE,
                };
                report.solver = match (p.solver, use_pgs) {
                    (SolverChoice::Auto, true) => "pgs (auto: size)",
                    (SolverChoice::Auto, false) => "lemke (auto)",
                    (s, _) => s.as_str(),
                };
                if !use_pgs {
                    // The last step's support first, carried over by
                    // contact identity: a resting or steadily sliding
                    // contact keeps it, and then no pivoting is needed.
                    let guess = (p.skips.lemke_guess
                        && carry_guess(&self.state, m, &ws.contacts, &mut ws.guess))
                    .then_some(&ws.guess[..]);
                    let solved = fallback::solve(
                        &mut self.lemke,
                        m,
                        guess,
                        step,
                        &mut ws.nu,
                        &mut ws.fallback,
                    );
                    match solved {
                        Ok(s) => {
                            relaxed = report.took(s.fallback, s.energy_refused, s.allowance);
                            if relaxed {
                                let fallback = &ws.fallback;
                                mark_drifted(m, &ws.groups, |g| fallback.fell(g), &mut ws.drifted);
                            }
                            report.lemke_islands = ws.fallback.islands();
                            report.pgs_islands = 0;
                            let info = s.info;
                            report.pivots += info.work;
                            report.regularized += usize::from(info.regularized());
                            report.refined += usize::from(info.refined);
                            report.rung = report.rung.max_by_ladder(info.rung);
                            report.residual = report.residual.max(info.residual);
                        }
                        // auto: the fallback the step report names.
                        Err(
                            LemkeError::RayTermination { .. }
                            | LemkeError::PivotLimit { .. }
                            | LemkeError::NumericalBreakdown { .. },
                        ) if p.solver == SolverChoice::Auto => {
                            use_pgs = true;
                            report.solver = "pgs (auto: lemke failed)";
                        }
                        Err(e) => return Err(StepError::Lemke(e)),
                    }
                }
                // Whether a PGS answer is final without the canonical
                // re-solve (see the NOTE below).
                pgs_settled = false;
                pgs_solved = use_pgs;
                if use_pgs {
                    // auto on a large step: Lemke still takes the small
                    // islands (split.rs), from the last support.
                    let by_size = p.solver == SolverChoice::Auto && n > AUTO_PGS_SIZE;
                    let exact = by_size.then(|| iterative::Exact {
                        guess: (p.skips.lemke_guess
                            && carry_guess(&self.state, m, &ws.contacts, &mut ws.guess))
                        .then_some(&ws.guess[..]),
                        lemke: &mut self.lemke,
                    });
                    let budget = PgsParams {
                        max_iterations: sweeps_left,
                        ..self.pgs_params
                    };
                    let mut solvers = iterative::Solvers {
                        pgs: &mut self.pgs,
                        params: &budget,
                        exact,
                        from_attempt,
                    };
                    let solved = iterative::solve(
                        &mut solvers,
                        m,
                        &self.state,
                        step,
                        &mut ws.nu,
                        &mut ws.iterative,
                    );
                    relaxed = report.took(solved.fallback, solved.energy_refused, solved.allowance);
                    if relaxed {
                        let iterative = &ws.iterative;
                        mark_drifted(m, &ws.groups, |g| iterative.fell(g), &mut ws.drifted);
                    }
                    let exact = ws.iterative.exact();
                    report.lemke_islands = exact.islands;
                    report.pgs_islands = ws.iterative.iterated();
                    if exact.islands > 0 {
                        report.solver = if report.pgs_islands > 0 {
                            "lemke+pgs (auto: by island)"
                        } else {
                            "lemke (auto: by island)"
                        };
                        report.rung = report.rung.max_by_ladder(exact.rung);
                        report.refined += usize::from(exact.refined);
                    }
                    sweeps_left = sweeps_left.saturating_sub(solved.info.iterations);
                    report.pivots += solved.info.iterations + exact.pivots;
                    report.residual = report.residual.max(solved.info.residual);
                    report.not_converged |= !solved.info.converged;
                    pgs_settled = solved.info.converged
                        && solved.fallback.is_none()
                        && self.pgs_params.stop == Stop::Residual;
                }
            }
            clock.timings.solve += clock.lap.lap();
            // A sleeping body's velocities are its free velocity, zero,
            // plus its zero inverse mass times impulses that are finite
            // where the awake bodies' velocities are.
            let finite = |&i: &u32| {
                ws.nu[6 * i as usize..6 * i as usize + 6]
                    .iter()
                    .all(|x| x.is_finite())
            };
            if !ws.awake.bodies().iter().all(finite) {
                return Err(StepError::NonFinite);
            }
            // Pairs the new velocities could bring into reach are listed
            // first, left out, so that the check below tests them too. The
            // list's indices then changed: the LCP's contacts are found
            // again by id, and its matrix and answer stand (the same rows;
            // solving it again gave the same bits and cost a whole solve:
            // measured, a third of a settling pile's sweeps).
            if ws.widen(model, &self.state, Speeds::New) {
                let kept = &ws.kept;
                ws.mlcp.remap(|ci| kept[ci].0, &ws.contacts);
            }
            let added = prune::check_left_out(&mut ws.contacts, &ws.nu, p.h, relaxed);
            if added > 0 {
                if sweeps_left == 0 {
                    // The answer stands, short of the contacts it would
                    // close: they enter the next step's LCP, as
                    // penetrating contacts if they close within this one.
                    report.not_converged = true;
                    report.left_out = added;
                    return Ok(());
                }
                report.resolves += 1;
                // Not for the canonical re-solve below: its answer must
                // depend on its contact set alone (prune.rs).
                from_attempt = pgs_solved;
                if pgs_solved {
                    ws.iterative.keep_attempt(&ws.mlcp, &ws.contacts);
                }
                continue;
            }
            from_attempt = false;
            // NOTE: once, after the first accepted solve: re-solve on the
            // active contacts only, so that the answer depends on the active
            // set alone (see prune.rs). Not after a converged rigid PGS
            // answer under the residual rule (piles): that answer is defined
            // to a loose tolerance only, and the re-solve cost as many
            // sweeps again (the 1,000 pile, 300 steps: 12.4 s against 6.1
            // s). Under the distance rule it stays: pruned and full runs
            // then give the same bits, and on the reference scene's
            // closed-loop steps, without it, the energy check relaxed 733
            // steps in a row (10 s: 2.5 million sweeps against 0.2).
            if canonical || pgs_settled || sweeps_left == 0 {
                return Ok(());
            }
            canonical = true;
            if !prune::keep_active(&mut ws.contacts, &ws.mlcp, &ws.nu) {
                return Ok(());
            }
        }
    }
}

/// Marks in `drifted` the bodies on the joint rows of the islands that
/// `fell` back: their relaxed problem had no drift term, so the next
/// step's projection holds their joints together (`integrate::project`).
fn mark_drifted(
    m: &crate::solver::mlcp::Mlcp,
    groups: &island::Groups,
    fell: impl Fn(usize) -> bool,
    drifted: &mut [bool],
) {
    for (k, row) in m.rows[..m.nb].iter().enumerate() {
        if fell(groups.island_of_row(k)) {
            for j in [row.a, row.b].into_iter().flatten() {
                drifted[j.body] = true;
            }
        }
    }
}
