//! Performance: the minimal C FMU the figures are measured against ([`fixture`]) and the one
//! loop that times FMUs through their C ABI ([`raw`]) (`docs/performance.md`).

pub mod fixture;
pub mod raw;
