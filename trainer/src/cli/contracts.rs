//! What each JSON the trainer writes is made of: every contract of [`schema`] it writes, paired
//! with the type its body is written from. docs/json.md lists their fields from here (generated;
//! a test fails where the page differs).

use fog_data::allan::Analysis;
use fog_terminal::schema::{self, Contract, PerChannel, PerFile};

use super::challenge::ChallengeReport;
use crate::analysis::reproduce::Reproduction;
use crate::firmware::unit::UnitFootprint;
use crate::pipeline::ChannelEntry;
use crate::pipeline::diagnose::Diagnosed;
use crate::pipeline::fit::report::UnitFitReport;
use crate::pipeline::investigate::UnitInvestigation;
use crate::pipeline::loo::Loo;
use crate::pipeline::summarize::ChannelSummary;
use crate::report::unit::UnitFigures;

/// The trainer's contracts, in [`schema::ALL`]'s order.
pub fn contracts() -> Vec<Contract> {
    vec![
        Contract::of::<PerFile<'static, Vec<ChannelSummary>>>(schema::SUMMARIZE),
        Contract::of::<UnitFitReport<'static>>(schema::FIT),
        Contract::of::<UnitFootprint>(schema::INSPECT),
        Contract::of::<PerChannel<'static, ChannelEntry<'static, Diagnosed>>>(schema::DIAGNOSE),
        Contract::of::<UnitInvestigation<'static>>(schema::INVESTIGATE),
        Contract::of::<Loo>(schema::LOO),
        Contract::of::<Reproduction>(schema::REPRODUCE),
        Contract::of::<ChallengeReport<'static>>(schema::CHALLENGE),
        Contract::of::<UnitFigures<'static>>(schema::REPORT),
        Contract::of::<PerChannel<'static, ChannelEntry<'static, Analysis>>>(schema::ALLAN),
        Contract::of::<Analysis>(schema::ALLAN_ANALYSIS),
    ]
}
