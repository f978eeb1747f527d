//! Which effect: the list of effects (the one place each effect's name is written) and
//! [`EffectKind`], the run-time handle of an effect type.
//!
//! The list sits below both [`crate::effects`] (the effect types, their physics and library
//! forms) and the parameter rows ([`crate::param_row`], whose group names the effect a row
//! belongs to), so that neither has to reach into the other for an effect's name: the effects
//! build their rows from it, the registry places those rows, and nothing here knows either.
//! `for_each_effect!` hands the list to a macro, here to make [`EffectKind`] and [`NAMES`],
//! in [`crate::effects`] to make the model file's `effects` section and each type's slot.
//!
//! **Adding an effect**: one line in the list below (its name as in the model file and its
//! type in `effects/<name>.rs`); see [`crate::effects`] for the rest.

use std::fmt;

use serde::{Deserialize, Serialize};

/// Calls `$callback!` with the list of effects, `name: Type` each with its doc comment, in
/// the model file's and the reports' order. The name is the model file's key (and the prefix
/// of the registry's `<effect>.<field>`); the type is the effect's in [`crate::effects`].
macro_rules! for_each_effect {
    ($callback:ident) => {
        $callback! {
            /// Step-out of the swarm rotation (rotation reversal / phase lag near f_off).
            phase_lag: PhaseLag,
            /// Weakening confinement toward z_off.
            cohesion_loss: CohesionLoss,
            /// Slow or oscillating formation after an input change.
            formation_lag: FormationLag,
            /// Slow change of the swarm over a session.
            particle_drift: ParticleDrift,
            /// Swarm off the field axis.
            centroid_offset: CentroidOffset,
            /// Scale, offset or tilt of the measurement.
            camera_bias: CameraBias,
        }
    };
}
pub(crate) use for_each_effect;

/// [`EffectKind`] with its names, from the list.
macro_rules! kinds {
    ($($(#[$doc:meta])* $name:ident : $ty:ident),+ $(,)?) => {
        /// Which effect: the run-time handle of an effect type (a report, a CLI option or a
        /// learned term names an effect by it; its name is the model file's).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum EffectKind {
            $($(#[$doc])* $ty,)+
        }

        /// Names of the effects, as in the model file and docs/effects.md, in list order.
        pub const NAMES: [&str; [$(stringify!($name)),+].len()] = [$(stringify!($name)),+];

        impl EffectKind {
            /// Every effect, in list order (the model file's and the reports' order).
            pub const ALL: [EffectKind; NAMES.len()] = [$(EffectKind::$ty),+];

            /// The effect's name in the model file (`phase_lag`, ...).
            pub const fn name(self) -> &'static str {
                match self {
                    $(EffectKind::$ty => stringify!($name),)+
                }
            }
        }
    };
}

for_each_effect!(kinds);

/// A name that is not an effect's.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown effect {name:?} (effects: {known})")]
pub struct UnknownEffect {
    /// The name given.
    pub name: String,
    /// The names of the effects, comma-separated.
    pub known: String,
}

impl EffectKind {
    /// The effect of a name (the model file's), if any.
    pub fn from_name(name: &str) -> Option<EffectKind> {
        EffectKind::ALL.into_iter().find(|k| k.name() == name)
    }
}

impl fmt::Display for EffectKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for EffectKind {
    type Err = UnknownEffect;
    fn from_str(s: &str) -> Result<EffectKind, UnknownEffect> {
        EffectKind::from_name(s).ok_or_else(|| UnknownEffect {
            name: s.to_string(),
            known: NAMES.join(", "),
        })
    }
}

impl Serialize for EffectKind {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for EffectKind {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<EffectKind, D::Error> {
        let s = String::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_are_refused_naming_the_known_ones() {
        for k in EffectKind::ALL {
            assert_eq!(k.name().parse::<EffectKind>(), Ok(k));
            assert_eq!(EffectKind::from_name(&k.to_string()), Some(k));
        }
        let e = "phase_lags".parse::<EffectKind>().unwrap_err();
        assert!(e.to_string().contains("phase_lag, cohesion_loss"), "{e}");
        let k: EffectKind = serde_json::from_str("\"camera_bias\"").unwrap();
        assert_eq!(k, EffectKind::CameraBias);
        assert_eq!(serde_json::to_string(&k).unwrap(), "\"camera_bias\"");
    }
}
