//! Geometry of a level (spec §6): `predict` (modes 0-2: context, passes, predictors, lines,
//! §6.2-§6.7), `fixed` (mode 3's integer geometry, §6.8) and `residuals` (the stream's layout,
//! §6.1, §6.6).

pub mod fixed;
pub mod predict;
pub mod residuals;
