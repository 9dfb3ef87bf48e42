//! Lemke's warm start: the last step's final support carried over to this
//! step's LCP by contact identity.

use crate::constraint::contact::Contact;
use crate::model::State;
use crate::solver::mlcp::Mlcp;

/// Lemke's guess for this step's LCP from the last step's final one, by
/// contact identity (as PGS's warm start): each contact that was in it with
/// the same rows keeps its normal, friction and slack flags; a new contact
/// starts inactive. Into `guess`; false when nothing carries over.
///
/// By identity rather than only for an identical layout, so that pruned and
/// full runs stay bit-identical (prune.rs): the full LCP of a run with
/// `full = true` holds the pruned one's contacts plus inactive ones, and
/// gets the same support, hence the same answer, where the guess holds.
pub fn carry_guess(state: &State, m: &Mlcp, contacts: &[Contact], guess: &mut Vec<bool>) -> bool {
    let (nc, nd, nm) = (m.nc, m.nd, m.nm);
    guess.clear();
    guess.resize(m.lcp_size(), false);
    let prev = &state.warm_lcp;
    let prev_nf = prev.iter().filter(|&&(_, f)| f).count();
    // The last LCP: [p_n; p_f; p_m; s; s_m], the motors the same ones.
    let prev_rows = prev.len() + prev_nf * nd + 2 * nm;
    if state.warm_active.len() != prev_rows + prev_nf + nm || prev.len() + nm == 0 {
        return false;
    }
    // Every motor is in every step's LCP: its pair and slack carry over.
    for k in 0..nm {
        let (src, dst) = (prev.len() + prev_nf * nd + 2 * k, m.motor_pair(k));
        guess[dst..dst + 2].copy_from_slice(&state.warm_active[src..src + 2]);
        guess[m.contact_rows() + m.nf + k] = state.warm_active[prev_rows + prev_nf + k];
    }
    let mut any = nm > 0;
    let mut friction = m.friction_of.iter().enumerate().peekable();
    // Both lists ascend by id (the LCP's contacts are in the contact
    // list's canonical order): one merge, O(n), where a search per contact
    // was O(n^2) (measured: 3 ms a step on the 1,000 pile). `pf` counts
    // the friction contacts of `prev[..j]`.
    let (mut j, mut pf) = (0, 0);
    for (i, &ci) in m.lcp_contacts.iter().enumerate() {
        let f = friction.next_if(|(_, &row)| row == i).map(|(f, _)| f);
        let id = contacts[ci].id;
        while j < prev.len() && prev[j].0 < id {
            pf += usize::from(prev[j].1);
            j += 1;
        }
        if prev
            .get(j)
            .is_none_or(|&(pid, fr)| pid != id || fr != f.is_some())
        {
            continue;
        }
        guess[i] = state.warm_active[j];
        if let Some(f) = f {
            // The last step's friction block of contact j.
            let (src, dst) = (prev.len() + pf * nd, nc + f * nd);
            guess[dst..dst + nd].copy_from_slice(&state.warm_active[src..src + nd]);
            let (src_s, dst_s) = (prev_rows + pf, m.contact_rows() + f);
            guess[dst_s] = state.warm_active[src_s];
        }
        any = true;
    }
    any
}
