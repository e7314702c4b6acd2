//! How long work says how far it has come, without knowing who is watching: the command line draws
//! a bar from it (`cli`, with indicatif), a test or a notebook passes `&()` and sees nothing.
//! The library takes this trait rather than a terminal's type, so it runs the same under any
//! front end.

/// What a long computation reports: the steps it expects, the steps done, and what it is doing.
/// `Sync`, so that folds running in parallel report to one watcher.
pub trait Progress: Sync {
    /// `steps` more steps are expected (a fold, a seed, a stage).
    fn expect(&self, steps: u64);
    /// `steps` of them are done.
    fn advance(&self, steps: u64);
    /// What is being done now, in a few words.
    fn stage(&self, what: &str);
}

/// Nobody watching.
impl Progress for () {
    fn expect(&self, _: u64) {}
    fn advance(&self, _: u64) {}
    fn stage(&self, _: &str) {}
}
