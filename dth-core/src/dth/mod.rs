//! The DTH stepper (placeholder: filled by the stepper issue).
