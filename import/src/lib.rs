//! `cosim-import`: robot descriptions of other formats written as our
//! scene, read by `Scene::parse` so that its checks are the scene file's.
//! Pure: no IPC, no plotting, no engine; files are read and nothing is
//! written. URDF now, and scene files that place robots.

pub mod mesh;
pub mod problems;
pub mod scene;
pub mod urdf;
