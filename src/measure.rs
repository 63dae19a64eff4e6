//! Measurements of the skin's quality for benchmarks and tests, above the core (they run
//! whole skins): how much a surface flickers on particles that jitter in place, and what
//! an artist sees in a liquid's surface (bumps, droplets, sheets).

pub mod flicker;
pub mod look;
