//! magswarm: reduced-order model of magnetic microparticle swarms.
pub use magswarm_model as model;
