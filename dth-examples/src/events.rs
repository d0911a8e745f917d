//! A scene's events at run time: their conditions compiled for the system
//! ([`Conditions::compile`], `dth::runtime::StateFunction`), watched by every method's run
//! (`crate::driver::Watched`), and what fired kept per method ([`EventLog`], [`EventHit`]) for
//! the summary line, `summary.json`, `events.csv` and `index.html`.

use dth::nalgebra::{DefaultAllocator, Dim};
use dth::observer::{Observer, StepRecord};
use dth::runtime::{RuntimeError, StateFunction};
use dth::Alloc;
use serde::Serialize;

use crate::driver::{Condition, Watched};
use crate::scene::{EventSpec, Scene};

impl Condition for StateFunction {
    fn value(&self, t: f64, z: &[f64], scratch: &mut Vec<f64>) -> f64 {
        // A value that is not finite (or a state of another length) is the run's error,
        // naming the event.
        self.value_at(t, z, scratch).unwrap_or(f64::NAN)
    }
}

/// A scene's events, their conditions compiled.
#[derive(Debug)]
pub struct Conditions {
    specs: Vec<EventSpec>,
    functions: Vec<StateFunction>,
}

impl Conditions {
    /// The events of `scene`, each condition compiled for its system (`n` degrees of
    /// freedom, `time_dependent`: the extended layout).
    ///
    /// # Errors
    /// The engine's, for a condition validation did not check (a scene built by hand).
    pub fn compile(scene: &Scene, time_dependent: bool) -> Result<Self, RuntimeError> {
        let params: Vec<(&str, f64)> = scene.params.iter().map(|(k, v)| (k.as_str(), *v)).collect();
        let functions = scene
            .events
            .iter()
            .map(|e| StateFunction::new(&e.g, scene.q.len(), time_dependent, &params))
            .collect::<Result<_, _>>()?;
        Ok(Conditions {
            specs: scene.events.clone(),
            functions,
        })
    }

    /// What a run watches ([`crate::driver::Stop::with_events`]).
    pub fn watched(&self) -> Vec<Watched<'_>> {
        self.specs
            .iter()
            .zip(&self.functions)
            .map(|(spec, f)| Watched {
                name: &spec.name,
                stop: spec.stop,
                condition: f,
            })
            .collect()
    }
}

/// An event that fired in a method's run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EventHit {
    /// The event's name.
    pub name: String,
    /// Its time, located to roundoff.
    pub t: f64,
    /// The state there (physical; extended for a time-dependent system).
    pub z: Vec<f64>,
    /// It ended the run.
    pub stopped: bool,
}

/// The observer that keeps the events a run reports.
#[derive(Debug, Default)]
pub struct EventLog {
    /// The events' names and whether each stops the run, in the order watched.
    names: Vec<(String, bool)>,
    /// What fired.
    pub hits: Vec<EventHit>,
}

impl EventLog {
    /// A log of `scene`'s events.
    pub fn new(scene: &Scene) -> Self {
        EventLog {
            names: scene
                .events
                .iter()
                .map(|e| (e.name.clone(), e.stop))
                .collect(),
            hits: Vec::new(),
        }
    }

    /// The event that ended the run, if one did.
    pub fn stopped_by(&self) -> Option<&EventHit> {
        self.hits.iter().find(|h| h.stopped)
    }
}

impl<D: Dim> Observer<D> for EventLog
where
    DefaultAllocator: Alloc<D>,
{
    fn on_event(&mut self, event: usize, r: &StepRecord<D>) {
        let (name, stop) = self.names.get(event).cloned().unwrap_or_default();
        self.hits.push(EventHit {
            name,
            t: r.t,
            z: r.z.iter().copied().collect(),
            stopped: stop,
        });
    }
}
