//! Constraint rows: what the solve stage's problem is made of. A contact's
//! normal and friction directions, a joint's rows, a limit as a contact, a
//! motor's bounded row, a rotor's row, each as a [`rows::Row`] on at most two bodies; and
//! the applied impulses (inputs, gravity, forces) that give the free
//! velocity.

pub mod applied;
pub mod armature;
pub mod contact;
pub mod coupling;
pub mod joint;
pub mod limit;
pub mod motor;
pub mod rows;
