//! What the models get right and wrong, and the choices made on them: the prior mean's basis
//! ([`basis`]); the paper's evaluation ([`evaluate`], [`reproduce`]),
//! transients on a rate table ([`table`]), the residual diagnosis of a stream ([`diagnose`]), the
//! extension that answers it ([`extend`]), the forward-in-time investigation that decides whether
//! to ship it ([`investigate`]), the same check for a rate table pooled with a stream's samples
//! ([`pool`]), and the hidden-effect challenge that measures all of this on the
//! simulator ([`challenge`]); the size of a model the firmware can hold, chosen on the data
//! ([`capacity`]), and of a unit's models within a target's budget ([`budget`]); the σ it
//! states, measured on its own training data ([`uncertainty`]); what the autopilots' cubic costs
//! against them, held out ([`autopilot`]).

pub mod autopilot;
pub mod basis;
pub mod beyond;
pub mod budget;
pub mod capacity;
pub mod challenge;
pub mod diagnose;
pub mod evaluate;
pub mod extend;
pub mod investigate;
pub mod pool;
pub mod reproduce;
pub mod table;
pub mod uncertainty;
