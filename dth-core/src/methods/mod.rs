//! Peer integrators, one per module (placeholder: filled by the stepper issue).
