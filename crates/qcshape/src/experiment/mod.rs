//! The experiments of the paper's section 3, each a library call with a report (CSV, Markdown, figures).

pub mod transfer;
