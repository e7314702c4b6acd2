//! What each JSON the trainer writes is made of: every contract of [`schema`] it writes, paired
//! with the type its body is written from. docs/json.md lists their fields from here (generated;
//! a test fails where the page differs).

use fog_data::allan::Analysis;
use fog_terminal::schema::{self, Contract, PerChannel, PerFile};

use super::challenge::ChallengeReport;
use crate::analysis::diagnose::Diagnosis;
use crate::analysis::investigate::Investigation;
use crate::analysis::reproduce::Reproduction;
use crate::firmware::export::Footprint;
use crate::firmware::unit::UnitFootprint;
use crate::pipeline::ChannelEntry;
use crate::pipeline::diagnose::Diagnosed;
use crate::pipeline::fit::report::{FitReport, UnitFitReport};
use crate::pipeline::investigate::UnitInvestigation;
use crate::pipeline::loo::Loo;
use crate::pipeline::summarize::SummarizedFile;
use crate::report::Figures;
use crate::report::unit::UnitFigures;

/// The trainer's contracts, in [`schema::ALL`]'s order.
pub fn contracts() -> Vec<Contract> {
    vec![
        Contract::of::<PerFile<'static, SummarizedFile>>(schema::SUMMARIZE),
        Contract::of::<FitReport>(schema::FIT),
        Contract::of::<UnitFitReport<'static>>(schema::FIT_UNIT),
        Contract::of::<Footprint>(schema::INSPECT),
        Contract::of::<UnitFootprint>(schema::INSPECT_UNIT),
        Contract::of::<Diagnosis>(schema::DIAGNOSE),
        Contract::of::<PerChannel<'static, ChannelEntry<'static, Diagnosed>>>(
            schema::DIAGNOSE_UNIT,
        ),
        Contract::of::<Investigation>(schema::INVESTIGATE),
        Contract::of::<UnitInvestigation<'static>>(schema::INVESTIGATE_UNIT),
        Contract::of::<Loo>(schema::LOO),
        Contract::of::<Reproduction>(schema::REPRODUCE),
        Contract::of::<ChallengeReport<'static>>(schema::CHALLENGE),
        Contract::of::<Figures<'static>>(schema::REPORT),
        Contract::of::<UnitFigures<'static>>(schema::REPORT_UNIT),
        Contract::of::<Analysis>(schema::ALLAN),
        Contract::of::<PerChannel<'static, ChannelEntry<'static, Analysis>>>(schema::ALLAN_UNIT),
    ]
}
