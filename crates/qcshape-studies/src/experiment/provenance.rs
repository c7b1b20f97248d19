//! Where a report comes from: the command line, the version, the machine and the run time.

/// The provenance lines of a report.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Provenance {
    /// The command line, arguments joined by spaces.
    pub command: String,
    /// The qcshape version.
    pub version: String,
    /// Operating system (`std::env::consts::OS`).
    pub os: String,
    /// Architecture (`std::env::consts::ARCH`).
    pub arch: String,
    /// Worker threads of the current rayon pool.
    pub threads: usize,
    /// Total wall-clock seconds of the run.
    pub seconds: f64,
}

impl Provenance {
    /// The provenance of a run of `command` (arguments joined by spaces) that took `seconds`,
    /// on this machine, in the current rayon pool.
    pub fn current(command: String, seconds: f64) -> Provenance {
        Provenance {
            command,
            version: env!("CARGO_PKG_VERSION").to_string(),
            os: std::env::consts::OS.to_string(),
            arch: std::env::consts::ARCH.to_string(),
            threads: rayon::current_num_threads(),
            seconds,
        }
    }

    /// Two Markdown lines: ``Command: `...` `` (with a hard line break) and
    /// `qcshape VERSION (OS ARCH), N worker threads, total S s.`, then an empty line.
    pub fn to_markdown(&self) -> String {
        format!(
            "Command: `{}`  \nqcshape {} ({} {}), {} worker threads, total {:.1} s.\n\n",
            self.command, self.version, self.os, self.arch, self.threads, self.seconds
        )
    }
}
