//! Scene files: parsing (TOML, serde, unknown keys rejected) and validation against the
//! systems a [`SystemLookup`] knows, with every error located at `file:line:column`.
//!
//! Layers, imports pointing down: `validate` (the rules) -> `members` (ensemble scenes),
//! `expression` (a Hamiltonian given as text, read by the symbolic engine), `events`
//! (`[[event]]` conditions, compiled by the same engine) and
//! `regularization` (`[system] regularize`, checked by the engine) -> `toml_string`
//! (where each byte of a TOML string comes from in the file) -> `raw` (the serde types, as
//! written), `schema` (the validated types the rest of the crate works with) and `suggest`
//! (the known name closest to a misspelled one); `structure` reads the file past its first
//! structural error, so that every problem is reported at once.
//!
//! A scene declares a system and its parameters, the initial state, the methods with their
//! steps, the duration and the effects wanted:
//!
//! ```toml
//! title = "Kepler, thesis Table 4.1 settings"
//!
//! [system]
//! name = "kepler"
//! params = { m = 0.5, k = 1.0 }
//!
//! [initial]
//! q = [0.5, 0.0]
//! p = [0.0, 1.2]
//!
//! [[method]]
//! kind = "dth"
//! dtau = 0.06277
//! lambda0 = 1.0
//!
//! [[method]]
//! kind = "trapezoidal"
//! dt = 0.15
//!
//! [duration]
//! steps = 10000            # or: time = 100.0, or: orbits = 400
//!
//! [[effect]]
//! kind = "energy_deviation"
//! ```
//!
//! Instead of a catalogue `name`, `[system]` may give the Hamiltonian as text, in the grammar
//! of `hamiltonian!` (`hamiltonian = "(p1^2 + p2^2)/(2*m) - k*(q1^2 + q2^2)^(-1/2)"`, with
//! `params` and an optional `title`): see `expression` and [`TextHamiltonian`].

mod events;
mod expression;
mod initial;
mod members;
mod raw;
mod regularization;
mod schema;
mod sizes;
mod structure;
mod suggest;
mod toml_string;
mod validate;

pub use events::condition_function;
pub use regularization::{translated, IndexedCentre};
pub(crate) use schema::thousands;
pub use schema::{
    component_names, Axis, AxisRange, ChaosIndicator, Coord, Direction, Duration, EffectKind,
    EffectSpec, EnergyShell, Ensemble, EventSpec, Members, MethodKind, MethodSpec, Regularization,
    RegularizeMap, Sampler, Sampling, Scene, StepSpec, TextHamiltonian,
};
pub use validate::{line_col, parse, ParamRule, ParamSpec, SystemInfo, SystemLookup};
