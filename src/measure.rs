//! Measurements of the skin's quality for benchmarks and tests, above the core (they run
//! whole skins): how much a surface flickers on particles that jitter in place.

pub mod flicker;
