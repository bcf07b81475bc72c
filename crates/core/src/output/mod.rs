//! Output formats: the JSON summary and full result of a solve, and VTU files (with a PVD index
//! for a series of scenarios) for ParaView, PyVista and meshio (design §5.6).

pub mod contact_profile;
pub mod pvd;
pub mod result;
pub mod solution_grid;
pub mod vtu;
