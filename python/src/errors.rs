//! The library's errors raised as Python's, said in its words.

use super::*;

pub(crate) fn value_error(e: FrameError) -> PyErr {
    match &e {
        // Refused before allocating: Python's own word for it, which a caller can catch.
        FrameError::OverBudget { .. } | FrameError::Skin(SkinError::OverBudget { .. }) => {
            PyMemoryError::new_err(said(&e))
        }
        _ => PyValueError::new_err(said(&e)),
    }
}

/// A library message as Python says it: each field it names as the argument that sets it
/// (`radius=`), not as the command's flag.
pub(crate) fn said(message: &impl ToString) -> String {
    spell(&message.to_string(), |field| match field {
        Field::TargetUnits => "units=".into(),
        Field::NoVelocity => "velocities=False".into(),
        Field::MaxMemory => "activeskin.set_memory_budget()".into(),
        Field::Target | Field::Particles => "pattern".into(),
        Field::Usd => "the stage".into(),
        Field::ShotFrames => "frames=".into(),
        other => format!("{}=", other.name()),
    })
}

/// The error of a VDB file asked of a wheel built without OpenVDB.
#[cfg(not(feature = "vdb"))]
pub(crate) fn no_vdb() -> PyErr {
    PyRuntimeError::new_err(
        "this activeskin was built without OpenVDB: build the wheel with `maturin build --release --features vdb` (needs libopenvdb-dev) to read and write VDB files",
    )
}
