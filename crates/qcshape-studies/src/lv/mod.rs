//! The left-ventricle pipeline's image side (paper section 4; docs/method.md "Left ventricle"):
//! 4D images and landmarks in, one deformation (a pose per frame on one connectivity) per
//! subject out.
//!
//! 1. [`qcshape::io::nifti`]: NIfTI-1 volumes with their voxel-to-world affine.
//! 2. [`phantom`] + [`anatomy`]: a CT-like phantom cohort (controls and HCM) with landmarks.
//! 3. [`tps`]: landmark thin-plate splines from frame 0 to every frame (section 4.2 step 1).
//! 4. [`surface`] + [`meshing`]: the cavity surface of frame 0 at a threshold (step 2),
//!    carried to every frame through the splines (step 3, [`cohort::Registration::carry`]),
//!    then [`refine`]d on each frame's own image (the wall's position across the surface).
//! 5. [`freewall`]: the free-wall faces as an open submesh (section 4.3).
//! 6. [`region`]: the phantom's abnormal region (known by construction) as a per-vertex weight.
//!
//! [`cohort`] holds the folder layout and the per-subject steps.
//!
//! The analysis (section 4.3): [`cohort_mesh`] puts a whole cohort on one connectivity,
//! [`study`] runs the classification (Tables 4 and 5; each subject's rigid pose removed by
//! [`qcshape::align`] before transfer) beside the radial baselines of [`analysis`],
//! [`cycle_map`] maps one cycle (Fig. 9), and [`study_report`] writes their Markdown and CSV;
//! [`pipeline`] runs them in order, as `qcshape lv run` does.

pub mod analysis;
pub mod anatomy;
pub mod cohort;
pub mod cohort_mesh;
pub mod cycle_map;
pub mod freewall;
pub mod landmarks;
pub mod meshing;
pub mod motion_report;

pub mod phantom;
pub mod pipeline;
pub mod refine;
pub mod region;
pub mod study;
pub mod study_report;
pub mod surface;
pub mod tps;

pub use cohort::{LayoutProblem, LvError, Registration, SubjectDir};
pub use freewall::{free_wall, LvAxis, SectorOptions, Submesh};
pub use landmarks::{read_landmarks, write_landmarks, Landmarks};
pub use meshing::{extract_surface, Surface, SurfaceOptions};
pub use qcshape::io::nifti::{read_series, read_volume, write_series, write_volume, Volume};
pub use tps::Tps;
