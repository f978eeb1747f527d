//! Performance yardsticks: the minimal C FMU the figures are measured against
//! (`docs/performance.md`).

pub mod fixture;
