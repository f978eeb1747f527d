//! What can stop a diagnosis, each naming the log and what it lacks.

/// An error of `diagnose`: a log that cannot support a diagnosis, or a step that failed.
#[derive(Debug, thiserror::Error)]
pub enum DiagnoseError {
    /// A log without radii.
    #[error("{source_name}: no r1_mm, r2_mm columns: diagnose needs measured radii")]
    NoRadii {
        /// The log.
        source_name: String,
    },
    /// Too few operating points.
    #[error(
        "{source_name}: too few operating points: {points} distinct (z_m, f) pair(s) with valid \
         radii; a diagnosis needs at least 6 (the baseline alone has 8 free parameters on 2 \
         radii per point, and the gap is judged by its structure over the points)"
    )]
    TooFewPoints {
        /// The log.
        source_name: String,
        /// Distinct operating points.
        points: usize,
    },
    /// One frequency only.
    #[error(
        "{source_name}: one frequency only ({f_hz} Hz): the frequency dependence of the model \
         and the frequency effects (phase lag) cannot be judged; add visits at other frequencies"
    )]
    OneFrequency {
        /// The log.
        source_name: String,
        /// The frequency \[Hz\].
        f_hz: f64,
    },
    /// One distance only.
    #[error(
        "{source_name}: one z_m only ({z_mm} mm): the distance dependence cannot be judged; add \
         visits at other distances"
    )]
    OneDistance {
        /// The log.
        source_name: String,
        /// The distance \[mm\].
        z_mm: f64,
    },
    /// A parameter to hold that the baseline does not fit.
    #[error("--fix {name}: not a free parameter of the baseline (those are {})", free.join(", "))]
    NotFree {
        /// The name asked for.
        name: String,
        /// The baseline's free parameters.
        free: Vec<String>,
    },
    /// Too few visits to decide (no repeats).
    #[error(
        "{source_name}: too few visits to decide: {visits} visit(s) and no repeats (no operating \
         point visited twice), while the baseline alone has {free} free parameters; the gap is \
         judged by the structure the visits leave beyond the baseline, which needs at least \
         {need} visits (or revisit points)"
    )]
    TooFewVisits {
        /// The log.
        source_name: String,
        /// Visits.
        visits: usize,
        /// Free parameters of the baseline.
        free: usize,
        /// Visits needed.
        need: usize,
    },
    /// Too little data to estimate the visit-to-visit noise.
    #[error("{source_name}: {source}")]
    Noise {
        /// The log.
        source_name: String,
        /// What is missing.
        #[source]
        source: super::noise::TooFew,
    },
    /// The baseline could not be identified.
    #[error("fitting the baseline (identify): {0}")]
    Baseline(#[source] magswarm_identify::IdentifyError),
    /// A session could not be replayed through the baseline.
    #[error("replaying session {session} through the baseline: {source}")]
    Replay {
        /// The session.
        session: String,
        /// Why.
        #[source]
        source: magswarm_identify::PredictError,
    },
    /// The gap tests' linear systems are singular.
    #[error("{source_name}: the gap tests could not be computed (singular design)")]
    GapTests {
        /// The log.
        source_name: String,
    },
    /// A withheld log without radii.
    #[error("{source_name}: the withheld log has no r1_mm, r2_mm columns")]
    WithheldNoRadii {
        /// The withheld log.
        source_name: String,
    },
    /// A withheld log without valid rows.
    #[error("{source_name}: the withheld log has no valid rows with radii")]
    WithheldEmpty {
        /// The withheld log.
        source_name: String,
    },
    /// A figure or file of the report could not be written.
    #[error(transparent)]
    Report(#[from] magswarm_report::ReportError),
    /// A model file of the report could not be written.
    #[error(transparent)]
    SaveModel(#[from] magswarm_model::ModelError),
}
