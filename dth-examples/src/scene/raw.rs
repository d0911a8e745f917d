//! The raw (as written) form of a scene file: every key is known (serde rejects the others),
//! every value that gets a semantic check is spanned so its errors point at it.

use std::collections::BTreeMap;

use serde::Deserialize;
use toml::Spanned;

use super::initial::RawValues;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawScene {
    pub(super) title: Option<String>,
    pub(super) description: Option<String>,
    pub(super) system: Option<Spanned<RawSystem>>,
    pub(super) initial: Option<Spanned<RawInitial>>,
    #[serde(rename = "method")]
    pub(super) methods: Option<Spanned<Vec<Spanned<RawMethod>>>>,
    pub(super) duration: Option<Spanned<RawDuration>>,
    #[serde(rename = "effect", default)]
    pub(super) effects: Vec<Spanned<RawEffect>>,
    #[serde(rename = "event", default)]
    pub(super) events: Vec<Spanned<RawEvent>>,
    pub(super) ensemble: Option<Spanned<RawEnsemble>>,
    pub(super) thesis_figures: Option<Spanned<bool>>,
}

/// `[ensemble]`: the thesis's square (no `kind`), or an ensemble scene (`kind = "grid" |
/// "random" | "list"`, see `super::members`). Which keys each kind takes is checked there.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawEnsemble {
    pub(super) kind: Option<Spanned<String>>,
    pub(super) x: Option<Spanned<String>>,
    pub(super) y: Option<Spanned<String>>,
    pub(super) half_width: Option<Spanned<f64>>,
    pub(super) per_side: Option<Spanned<i64>>,
    pub(super) steps: Option<Spanned<i64>>,
    pub(super) x_range: Option<Spanned<Vec<f64>>>,
    pub(super) y_range: Option<Spanned<Vec<f64>>>,
    pub(super) x_count: Option<Spanned<i64>>,
    pub(super) y_count: Option<Spanned<i64>>,
    pub(super) samples: Option<Spanned<i64>>,
    pub(super) seed: Option<Spanned<i64>>,
    pub(super) members: Option<Spanned<String>>,
    pub(super) energy: Option<Spanned<f64>>,
    pub(super) solve: Option<Spanned<String>>,
    pub(super) chaos: Option<Spanned<String>>,
}

/// `[system]`: a catalogue system (`name`) or a Hamiltonian given as text (`hamiltonian`, and
/// optionally a `title` naming it); exactly one of the two, checked in `super::validate`. A text
/// may be regularized (`regularize`, about `centre`).
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSystem {
    pub(super) name: Option<Spanned<String>>,
    pub(super) hamiltonian: Option<Spanned<String>>,
    pub(super) title: Option<Spanned<String>>,
    #[serde(default)]
    pub(super) params: BTreeMap<Spanned<String>, Spanned<f64>>,
    /// The sizes of a Hamiltonian given as text (`super::sizes`).
    #[serde(default)]
    pub(super) sizes: BTreeMap<Spanned<String>, Spanned<i64>>,
    pub(super) regularize: Option<Spanned<String>>,
    pub(super) centre: Option<Spanned<Vec<f64>>>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawInitial {
    pub(super) q: Option<Spanned<RawValues>>,
    pub(super) p: Option<Spanned<RawValues>>,
    pub(super) t: Option<Spanned<f64>>,
    /// The seed of `random` in formulas (`super::initial`).
    pub(super) seed: Option<Spanned<i64>>,
    /// A CSV file of states, in place of `q` and `p` (`super::initial`).
    pub(super) file: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMethod {
    pub(super) kind: Spanned<String>,
    pub(super) label: Option<Spanned<String>>,
    pub(super) dt: Option<Spanned<f64>>,
    pub(super) dtau: Option<Spanned<f64>>,
    pub(super) lambda0: Option<Spanned<f64>>,
    pub(super) solver: Option<Spanned<String>>,
    pub(super) robust: Option<Spanned<bool>>,
    pub(super) order: Option<Spanned<i64>>,
    pub(super) double_double: Option<Spanned<bool>>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawDuration {
    pub(super) steps: Option<Spanned<i64>>,
    pub(super) time: Option<Spanned<f64>>,
    pub(super) orbits: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawEffect {
    pub(super) kind: Spanned<String>,
    pub(super) every: Option<Spanned<i64>>,
    pub(super) x: Option<Spanned<String>>,
    pub(super) y: Option<Spanned<String>>,
    pub(super) coordinate: Option<Spanned<String>>,
    pub(super) value: Option<Spanned<f64>>,
    pub(super) direction: Option<Spanned<String>>,
    pub(super) until: Option<Spanned<f64>>,
    pub(super) crossing: Option<Spanned<String>>,
    pub(super) modes: Option<Spanned<i64>>,
    pub(super) every_time: Option<Spanned<f64>>,
    pub(super) times: Option<Spanned<Vec<f64>>>,
    pub(super) period: Option<Spanned<f64>>,
    pub(super) phase: Option<Spanned<f64>>,
}

/// `[[event]]` (`super::events`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawEvent {
    pub(super) name: Option<Spanned<String>>,
    pub(super) when: Spanned<String>,
    pub(super) action: Option<Spanned<String>>,
}
