//! How long work says how far it has come ([`Progress`]), and what a command's pipeline says as it
//! goes ([`Messages`]), without knowing who is watching: the command line draws bars and prints
//! lines from them (`cli`, with indicatif), a test passes `&()` and sees nothing. The library takes
//! these traits rather than a terminal's types, so it runs the same under any front end.

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

/// What a command's pipeline tells whoever runs it, beside the typed result it returns: the
/// results worth a line as they are reached, warnings, details for the curious, and work of
/// unknown length. The command line prints them (`cli`, on its console); a test or a notebook
/// passes `&()` and reads the result alone.
pub trait Messages {
    /// A result worth a line of its own (a choice made and why, a figure measured).
    fn result(&self, text: &str);
    /// Something the person should act on or know, whatever else they asked to see.
    fn warn(&self, text: &str);
    /// Whether details ([`Messages::detail`]) are wanted: building them may cost.
    fn verbose(&self) -> bool {
        false
    }
    /// A detail (every optimizer start of a fit, …), shown only when asked for.
    fn detail(&self, _text: &str) {}
    /// Work of unknown length begins, described by `what`: the handle says what it does now,
    /// and the work ends when it is dropped.
    fn busy(&self, what: &str) -> Box<dyn Progress + '_>;
    /// Work counted in steps begins (it says how many it expects as it learns them), and ends
    /// when the handle is dropped.
    fn counted(&self) -> Box<dyn Progress + '_>;
    /// The messages about one channel of a unit, under its `heading` (said now, unless empty),
    /// named by `name`.
    fn channel(&self, name: &str, heading: &str) -> Box<dyn Messages + '_>;
}

/// Nobody listening.
impl Messages for () {
    fn result(&self, _: &str) {}
    fn warn(&self, _: &str) {}
    fn busy(&self, _: &str) -> Box<dyn Progress + '_> {
        Box::new(())
    }
    fn counted(&self) -> Box<dyn Progress + '_> {
        Box::new(())
    }
    fn channel(&self, _: &str, _: &str) -> Box<dyn Messages + '_> {
        Box::new(())
    }
}
