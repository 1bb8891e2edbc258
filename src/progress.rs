//! Progress of long jobs (blessing, verifying, the gate, the sweep), told to
//! whoever shows it: the command line draws a bar, the server and the tests
//! show nothing. The library never touches the terminal itself.

/// Receives a job's progress; every method does nothing unless overridden.
pub trait Progress: Sync {
    /// A job of `total` units (`unit`: "frames", "configurations") starts.
    fn start(&self, _job: &str, _total: u64, _unit: &str) {}
    /// What is being worked on now (a scene's name).
    fn working_on(&self, _what: &str) {}
    /// `n` more units are done.
    fn advance(&self, _n: u64) {}
    /// The job has ended.
    fn finish(&self) {}
}

/// Shows nothing.
pub struct Silent;

impl Progress for Silent {}
