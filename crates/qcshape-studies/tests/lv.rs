//! Left-ventricle image side: NIfTI, thin-plate splines, phantom, surfaces, free wall.

use qcshape::io::nifti::{
    parse_nifti, read_series, read_volume, write_series, NiftiError, NiftiParseError, Volume,
};
use qcshape::mesh::Shape;
use qcshape_studies::lv::cohort::Registration;
use qcshape_studies::lv::freewall::{free_wall, LvAxis, SectorOptions};
use qcshape_studies::lv::landmarks::{
    read_landmarks, write_landmarks, LandmarkError, APEX, BASE_CENTRE, SEPTUM,
};
use qcshape_studies::lv::meshing::{extract_surface, SurfaceOptions};
use qcshape_studies::lv::phantom::{subject, Group, PhantomOptions, PhantomSubject};
use qcshape_studies::lv::surface::{isosurface, otsu_thresholds, SurfaceError};
use qcshape_studies::lv::tps::{Tps, TpsError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn oblique_volume(dims: [usize; 3], seed: u64) -> Volume {
    let mut v = Volume::filled(dims, [0.5, 0.5, 0.625], [-12.0, 30.0, 4.5], 0.0);
    let (c, s) = (0.3f64.cos(), 0.3f64.sin());
    let r = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]];
    for (row, rr) in r.iter().enumerate() {
        for (col, x) in rr.iter().enumerate() {
            v.affine[row][col] = x * v.spacing[col];
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for x in &mut v.data {
        *x = rng.random_range(-1000.0..1000.0);
    }
    v
}

#[test]
fn nifti_round_trips_3d_4d_and_gzip() {
    let dir = tempfile::tempdir().unwrap();
    let v = oblique_volume([5, 4, 3], 1);
    for name in ["a.nii", "a.nii.gz"] {
        let p = dir.path().join(name);
        write_series(&p, std::slice::from_ref(&v)).unwrap();
        let back = read_volume(&p).unwrap();
        assert_eq!(back.dims, v.dims);
        assert_eq!(back.data, v.data, "{name}");
        for r in 0..4 {
            for c in 0..4 {
                assert!(
                    (back.affine[r][c] - v.affine[r][c]).abs() < 1e-5,
                    "{name}: {:?}",
                    back.affine
                );
            }
        }
        for a in 0..3 {
            assert!((back.spacing[a] - v.spacing[a]).abs() < 1e-6);
        }
    }
    let frames: Vec<Volume> = (0..3).map(|t| oblique_volume([4, 3, 2], 10 + t)).collect();
    let mut same_affine = frames.clone();
    for f in &mut same_affine {
        f.affine = frames[0].affine;
    }
    let p = dir.path().join("series.nii.gz");
    write_series(&p, &same_affine).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    assert_eq!(&bytes[..2], &[0x1f, 0x8b], "gzipped");
    let back = read_series(&p).unwrap();
    assert_eq!(back.len(), 3);
    for (a, b) in back.iter().zip(&same_affine) {
        assert_eq!(a.data, b.data);
    }
    // A 4D file is not a 3D volume; frames of different shapes cannot be one file.
    let err = read_volume(&p).unwrap_err();
    assert!(matches!(err, NiftiError::NotThreeD { frames: 3, .. }), "{err}");
    assert!(err.to_string().contains("series.nii.gz"));
    let mut bad = same_affine.clone();
    bad[1] = oblique_volume([3, 3, 2], 5);
    assert!(matches!(
        write_series(&dir.path().join("x.nii"), &bad),
        Err(NiftiError::Inconsistent { .. })
    ));
}

#[test]
fn nifti_bad_headers_are_typed_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let v = oblique_volume([4, 4, 4], 2);
    let p = dir.path().join("v.nii");
    write_series(&p, std::slice::from_ref(&v)).unwrap();
    let good = std::fs::read(&p).unwrap();
    let with = |f: &dyn Fn(&mut Vec<u8>)| {
        let mut b = good.clone();
        f(&mut b);
        b
    };
    // Truncated data.
    let b = with(&|b| b.truncate(b.len() - 7));
    assert!(matches!(parse_nifti(&b), Err(NiftiParseError::Truncated { .. })));
    // Wrong dimensions: 2D, zero size, a fifth dimension.
    let b = with(&|b| b[40..42].copy_from_slice(&2i16.to_le_bytes()));
    assert!(matches!(parse_nifti(&b), Err(NiftiParseError::Dimensions { .. })));
    let b = with(&|b| b[44..46].copy_from_slice(&0i16.to_le_bytes()));
    assert!(matches!(parse_nifti(&b), Err(NiftiParseError::Dimensions { .. })));
    let b = with(&|b| {
        b[40..42].copy_from_slice(&5i16.to_le_bytes());
        b[50..52].copy_from_slice(&2i16.to_le_bytes());
    });
    assert!(matches!(parse_nifti(&b), Err(NiftiParseError::Dimensions { .. })));
    // Unsupported datatype (RGB), not NIfTI, two-file magic, bad offset.
    let b = with(&|b| b[70..72].copy_from_slice(&128i16.to_le_bytes()));
    assert!(matches!(
        parse_nifti(&b),
        Err(NiftiParseError::Datatype {
            code: 128,
            name: "rgb24"
        })
    ));
    assert!(matches!(parse_nifti(b"hello"), Err(NiftiParseError::NotNifti(_))));
    let b = with(&|b| b[344..348].copy_from_slice(b"ni1\0"));
    assert!(matches!(parse_nifti(&b), Err(NiftiParseError::TwoFile)));
    let b = with(&|b| b[108..112].copy_from_slice(&100f32.to_le_bytes()));
    assert!(matches!(parse_nifti(&b), Err(NiftiParseError::VoxOffset(_))));
    // Through the file reader, the message names the file.
    let q = dir.path().join("short.nii");
    std::fs::write(&q, &good[..good.len() - 1]).unwrap();
    let msg = read_series(&q).unwrap_err().to_string();
    assert!(msg.contains("short.nii") && msg.contains("truncated"), "{msg}");
    // Corrupt gzip.
    let z = dir.path().join("bad.nii.gz");
    std::fs::write(&z, [0x1f, 0x8b, 8, 0, 1, 2, 3]).unwrap();
    assert!(matches!(
        read_series(&z),
        Err(NiftiError::Parse {
            error: NiftiParseError::Gzip(_),
            ..
        })
    ));
}

fn random_points(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| std::array::from_fn(|_| rng.random_range(-40.0..40.0)))
        .collect()
}

#[test]
fn tps_is_exact_at_landmarks_reproduces_affine_maps_and_is_bounded() {
    let src = random_points(32, 3);
    let warp = |p: [f64; 3]| {
        [
            p[0] + 3.0 * (p[1] / 20.0).sin(),
            p[1] + 2.0 * (p[2] / 15.0).cos(),
            0.9 * p[2] + 0.002 * p[0] * p[0],
        ]
    };
    let dst: Vec<[f64; 3]> = src.iter().map(|p| warp(*p)).collect();
    for n in [8, 16, 24, 32] {
        let t = Tps::fit(&src[..n], &dst[..n], 0.0).unwrap();
        for (p, q) in src[..n].iter().zip(&dst[..n]) {
            let r = t.apply(*p);
            let scale = q.iter().map(|c| c.abs()).fold(1.0, f64::max);
            for c in 0..3 {
                assert!((r[c] - q[c]).abs() <= 1e-9 * scale, "n = {n}: {r:?} vs {q:?}");
            }
        }
    }
    // Smooth elsewhere: on a grid inside the landmarks' box, the displacement stays within a
    // small multiple of the largest landmark displacement.
    let t = Tps::fit(&src, &dst, 0.0).unwrap();
    let max_disp = src
        .iter()
        .zip(&dst)
        .map(|(p, q)| (0..3).map(|c| (q[c] - p[c]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    for i in 0..9 {
        for j in 0..9 {
            for k in 0..9 {
                let p = [
                    -30.0 + 7.5 * i as f64,
                    -30.0 + 7.5 * j as f64,
                    -30.0 + 7.5 * k as f64,
                ];
                let r = t.apply(p);
                let d = (0..3).map(|c| (r[c] - p[c]).powi(2)).sum::<f64>().sqrt();
                assert!(d.is_finite() && d <= 3.0 * max_disp, "{p:?}: {d} vs {max_disp}");
            }
        }
    }
    // An affine map is reproduced exactly everywhere, with zero bending.
    let a = [[1.1, 0.2, -0.1], [0.05, 0.9, 0.3], [-0.2, 0.1, 1.2]];
    let b = [5.0, -3.0, 12.0];
    let aff = |p: [f64; 3]| -> [f64; 3] {
        std::array::from_fn(|r| b[r] + (0..3).map(|c| a[r][c] * p[c]).sum::<f64>())
    };
    let dst: Vec<[f64; 3]> = src.iter().map(|p| aff(*p)).collect();
    let t = Tps::fit(&src[..16], &dst[..16], 0.0).unwrap();
    for p in random_points(50, 9) {
        let (r, q) = (t.apply(p), aff(p));
        for c in 0..3 {
            assert!((r[c] - q[c]).abs() < 1e-9 * 100.0, "{r:?} vs {q:?}");
        }
    }
    assert!(t.bending_energy() < 1e-12 * 100.0, "{}", t.bending_energy());
    // Regularization trades exactness for less bending.
    let dst: Vec<[f64; 3]> = src.iter().map(|p| warp(*p)).collect();
    let exact = Tps::fit(&src, &dst, 0.0).unwrap();
    let smooth = Tps::fit(&src, &dst, 1.0).unwrap();
    assert!(smooth.bending_energy() < exact.bending_energy());
    assert!((0..32).any(|i| smooth.apply(src[i]) != dst[i]));
    // Degenerate inputs.
    let flat: Vec<[f64; 3]> = src.iter().map(|p| [p[0], p[1], 0.0]).collect();
    assert_eq!(Tps::fit(&flat, &dst, 0.0).unwrap_err(), TpsError::Coplanar);
    let mut dup = src.clone();
    dup[5] = dup[2];
    assert_eq!(Tps::fit(&dup, &dst, 0.0).unwrap_err(), TpsError::Duplicate(2, 5));
    assert!(matches!(
        Tps::fit(&src[..3], &dst[..3], 0.0),
        Err(TpsError::Count { .. })
    ));
    let mut nan = dst.clone();
    nan[0][1] = f64::NAN;
    assert!(matches!(Tps::fit(&src, &nan, 0.0), Err(TpsError::NonFinite(_))));
}

#[test]
fn landmark_files_with_missing_or_nan_rows_are_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("landmarks.csv");
    let ok = "frame,landmark,x,y,z\n0,0,1,2,3\n0,1,4,5,6\n1,0,1,2,3.5\n1,1,4,5,6.5\n";
    std::fs::write(&p, ok).unwrap();
    let lm = read_landmarks(&p).unwrap();
    assert_eq!((lm.n_frames(), lm.ids.len()), (2, 2));
    assert_eq!(lm.get(1, 1), Some([4.0, 5.0, 6.5]));
    let q = dir.path().join("copy.csv");
    write_landmarks(&q, &lm).unwrap();
    assert_eq!(read_landmarks(&q).unwrap(), lm);
    let cases = [
        (
            "frame,landmark,x,y,z\n0,0,1,2,3\n0,1,4,5,6\n1,0,1,2,3.5\n",
            "missing landmark(s) [1]",
        ),
        ("frame,landmark,x,y,z\n0,0,1,2,3\n0,1,4,NaN,6\n", "line 3"),
        (
            "frame,landmark,x,y,z\n0,0,1,2,3\n0,1,4,,6\n",
            "not a finite number",
        ),
        ("frame,landmark,x,y,z\n0,0,1,2,3\n0,0,4,5,6\n", "given twice"),
        ("frame,landmark,x,y\n0,0,1,2\n", "missing column \"z\""),
        (
            "frame,landmark,x,y,z\n0,0,1,2,3\n2,0,1,2,3\n",
            "frame 1 has no landmarks",
        ),
    ];
    for (text, want) in cases {
        std::fs::write(&p, text).unwrap();
        let e = read_landmarks(&p).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("landmarks.csv") && msg.contains(want), "{msg}");
        assert!(matches!(
            e,
            LandmarkError::Row { .. } | LandmarkError::Incomplete { .. }
        ));
    }
}

/// A ball of radius `r` mm (bright inside) on an anisotropic grid with an x-flipped affine.
fn ball(r: f64) -> Volume {
    let mut v = Volume::filled([30, 30, 24], [1.0, 1.0, 1.25], [14.5, -14.5, -14.375], 0.0);
    v.affine[0][0] = -1.0;
    let c = [0.3, 0.2, -0.1];
    for k in 0..24 {
        for j in 0..30 {
            for i in 0..30 {
                let w = v.to_world([i as f64, j as f64, k as f64]);
                let d = ((w[0] - c[0]).powi(2) + (w[1] - c[1]).powi(2) + (w[2] - c[2]).powi(2)).sqrt();
                let idx = v.index(i, j, k);
                // Smooth edge: 100 inside, 0 outside, 50 on the sphere.
                v.data[idx] = (50.0 * (1.0 - ((d - r) / 1.0).tanh())) as f32;
            }
        }
    }
    v
}

#[test]
fn sphere_volume_gives_a_closed_genus_zero_surface_of_the_right_radius() {
    let r = 9.0;
    let vol = ball(r);
    let raw = isosurface(&vol, 50.0).unwrap();
    let topo = raw.topology().unwrap();
    assert!(topo.boundary_loops().is_empty());
    assert_eq!(topo.genus(), Some(0));
    assert!(
        raw.signed_volume() > 0.0,
        "outward normals despite the flipped affine"
    );
    let c = [0.3, 0.2, -0.1];
    for p in &raw.positions {
        let d = ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt();
        assert!((d - r).abs() < 1.25, "vertex at radius {d}");
    }
    let s = extract_surface(
        &vol,
        &SurfaceOptions {
            threshold: None,
            target_vertices: Some(300),
            ..Default::default()
        },
    )
    .unwrap();
    let (lo, hi) = otsu_thresholds(&vol).unwrap();
    assert!(lo < hi && s.threshold == hi);
    let t = &s.shape.topology;
    assert_eq!((t.genus(), t.boundary_loops().len()), (Some(0), 0));
    assert!(
        s.shape.n_vertices() <= 400 && s.shape.n_vertices() >= 250,
        "{}",
        s.shape.n_vertices()
    );
    let mean_r = s
        .shape
        .positions
        .iter()
        .map(|p| ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt())
        .sum::<f64>()
        / s.shape.n_vertices() as f64;
    assert!((mean_r - r).abs() < 1.0, "mean radius {mean_r}");
    // A threshold above every voxel yields no surface.
    let e = isosurface(&vol, 1e4).unwrap_err();
    assert!(matches!(e, SurfaceError::Empty { .. }) && e.to_string().contains("no surface"));
}

fn small_subject(group: Group, seed: u64) -> PhantomSubject {
    let opts = PhantomOptions {
        size: 32,
        seed,
        ..Default::default()
    };
    subject("s", group, 0, &opts)
}

#[test]
fn phantom_is_deterministic_and_hcm_differs_from_controls_as_published() {
    let a = small_subject(Group::Control, 7);
    let b = small_subject(Group::Control, 7);
    assert_eq!(a.frames, b.frames);
    assert_eq!(a.landmarks, b.landmarks);
    assert_ne!(small_subject(Group::Control, 8).frames, a.frames);
    assert_eq!(a.frames.len(), 8);
    assert_eq!(a.landmarks.ids.len(), 32);
    // Measured from the images: cavity voxels (above the blood/myocardium midpoint) per frame,
    // and the free-wall thickness along a ray at mid-height through the sector's centre.
    let measure = |s: &PhantomSubject| {
        let counts: Vec<usize> = s
            .frames
            .iter()
            .map(|f| f.data.iter().filter(|&&v| v > 230.0).count())
            .collect();
        let (max, min) = (*counts.iter().max().unwrap(), *counts.iter().min().unwrap());
        let argmax = counts.iter().position(|&c| c == max).unwrap();
        let argmin = counts.iter().position(|&c| c == min).unwrap();
        let vox_ml = s.frames[0].voxel_volume() / 1000.0;
        let lm = &s.landmarks;
        let ed = argmax;
        let axis = LvAxis::new(
            lm.get(ed, APEX).unwrap(),
            lm.get(ed, BASE_CENTRE).unwrap(),
            lm.get(ed, SEPTUM).unwrap(),
        )
        .unwrap();
        let theta = s.model.free_wall_centre_deg.to_radians();
        let second = cross(axis.axis, axis.reference);
        let dir: [f64; 3] =
            std::array::from_fn(|c| theta.cos() * axis.reference[c] + theta.sin() * second[c]);
        let mid: [f64; 3] = std::array::from_fn(|c| axis.apex[c] + 0.55 * axis.length * axis.axis[c]);
        let vol = &s.frames[ed];
        let mut myo = 0;
        for step in 0..400 {
            let w: [f64; 3] = std::array::from_fn(|c| mid[c] + 0.1 * step as f64 * dir[c]);
            let v = vol.to_voxel(w).unwrap().map(|x| x.round() as usize);
            let val = vol.data[vol.index(v[0], v[1], v[2])];
            if (-345.0..230.0).contains(&val) {
                myo += 1;
            }
            if val < -345.0 && myo > 0 {
                break;
            }
        }
        (
            max as f64 * vox_ml,
            1.0 - min as f64 / max as f64,
            0.1 * myo as f64,
            (argmax, argmin),
        )
    };
    let (mut c_edv, mut c_fw, mut h_edv, mut h_fw) = (f64::MAX, 0.0f64, 0.0f64, f64::MAX);
    for seed in 1..=3 {
        for (group, slot) in [(Group::Control, 0), (Group::Hcm, 1)] {
            let s = small_subject(group, seed);
            let (edv, ef, fw, (ed, es)) = measure(&s);
            assert!((0.45..0.8).contains(&ef), "{group:?} seed {seed}: EF {ef}");
            assert!(
                [6, 7, 0].contains(&ed) && [2, 3, 4].contains(&es),
                "ED {ed}, ES {es}"
            );
            if slot == 0 {
                assert!(fw < 13.0, "control free wall {fw} mm");
                c_edv = c_edv.min(edv);
                c_fw = c_fw.max(fw);
            } else {
                assert!(fw >= 14.0, "HCM free wall {fw} mm");
                h_edv = h_edv.max(edv);
                h_fw = h_fw.min(fw);
            }
        }
    }
    assert!(h_fw > c_fw, "HCM free walls are thicker: {h_fw} vs {c_fw}");
    // Smaller cavities in HCM; the EF stays preserved (checked above), as published.
    assert!(
        h_edv < c_edv,
        "largest HCM EDV {h_edv} mL vs smallest control {c_edv} mL"
    );
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[test]
fn carried_meshes_share_connectivity_follow_the_wall_and_the_free_wall_is_a_disk() {
    let s = small_subject(Group::Hcm, 4);
    let surf = extract_surface(&s.frames[0], &SurfaceOptions::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let reg = Registration::fit(&s.landmarks, 16, 0.0, &dir.path().join("landmarks.csv")).unwrap();
    let poses = reg.carry(&surf.shape.positions);
    assert_eq!(poses.len(), 8);
    for p in &poses {
        let shape = Shape::new_checked(surf.shape.topology.clone(), p.clone(), 1e-12).unwrap();
        assert!(shape.check_same_topology(&surf.shape).is_ok());
    }
    // The carried end-systolic mesh sits on the cavity edge of the end-systolic image: the
    // mean intensity there is near the threshold, unlike the frame-0 mesh left in place.
    let es = 3;
    let vol = &s.frames[es];
    let sample = |pts: &[[f64; 3]]| {
        pts.iter()
            .map(|w| {
                let v = vol
                    .to_voxel(*w)
                    .unwrap()
                    .map(|x| x.round().clamp(0.0, 31.0) as usize);
                vol.data[vol.index(v[0], v[1], v[2])] as f64
            })
            .sum::<f64>()
            / pts.len() as f64
    };
    let carried = (sample(&poses[es]) - surf.threshold).abs();
    let left = (sample(&surf.shape.positions) - surf.threshold).abs();
    assert!(
        carried < 0.5 * left,
        "carried {carried} HU from the threshold, unmoved {left}"
    );
    // Free wall: one open disk, the same faces in every frame.
    let lm = &s.landmarks;
    let axis = LvAxis::new(
        lm.get(0, APEX).unwrap(),
        lm.get(0, BASE_CENTRE).unwrap(),
        lm.get(0, SEPTUM).unwrap(),
    )
    .unwrap();
    let sub = free_wall(
        &surf.shape.topology,
        &surf.shape.positions,
        &axis,
        &SectorOptions::default(),
    )
    .unwrap();
    assert_eq!(sub.topology.boundary_loops().len(), 1);
    assert_eq!(sub.topology.n_components(), 1);
    let n = sub.vertices.len();
    assert!(
        n > surf.shape.n_vertices() / 5 && n < surf.shape.n_vertices() / 2,
        "{n} free-wall vertices"
    );
    for p in &poses {
        let q = sub.restrict(p);
        assert_eq!(q.len(), n);
        Shape::new_checked(sub.topology.clone(), q, 1e-12).unwrap();
    }
    // Every kept face's centroid lies in (or, after clean-up, next to) the sector.
    let near = sub
        .faces
        .iter()
        .filter(|&&f| {
            let c = surf.shape.topology.faces()[f].iter().fold([0.0; 3], |a, &v| {
                std::array::from_fn(|k| a[k] + surf.shape.positions[v as usize][k] / 3.0)
            });
            let (_, ang, _) = axis.cylindrical(c);
            ang.abs() >= 80.0
        })
        .count();
    assert_eq!(near, sub.faces.len());
}

// ---- The harder (overlapping) phantom and the cohort study (section 4.3). ----

use qcshape::align::{Alignment, Motion};
use qcshape::cluster::ClusterMethod;
use qcshape::geodesic::GeodesicOptions;
use qcshape::similarity::PipelineOptions;
use qcshape::transport::Transport;
use qcshape_studies::lv::cohort::{write_labels, write_subject, LABELS_NAME};
use qcshape_studies::lv::cohort_mesh::{is_cohort, mesh_cohort, MeshSettings, MeshedCohort};
use qcshape_studies::lv::phantom::{overlap_model, roster, sample_model};
use qcshape_studies::lv::study::{analyse, baselines, compare_methods, labels_of, SplitOptions, Tick};

#[test]
fn overlap_phantom_is_deterministic_posed_noisy_and_its_groups_overlap() {
    let opts = PhantomOptions {
        size: 24,
        frames: 4,
        seed: 3,
        overlap: true,
        landmark_noise_mm: qcshape_studies::lv::phantom::OVERLAP_LANDMARK_NOISE_MM,
        ..Default::default()
    };
    let a = subject("s", Group::Hcm, 2, &opts);
    let b = subject("s", Group::Hcm, 2, &opts);
    assert_eq!(a.frames, b.frames);
    assert_eq!(a.landmarks, b.landmarks);
    assert_eq!(a.model, b.model);
    let plain = subject(
        "s",
        Group::Hcm,
        2,
        &PhantomOptions {
            overlap: false,
            ..opts.clone()
        },
    );
    assert_ne!(plain.model, a.model);
    let exact_lm = subject(
        "s",
        Group::Hcm,
        2,
        &PhantomOptions {
            landmark_noise_mm: 0.0,
            ..opts.clone()
        },
    );
    assert_eq!(exact_lm.model, a.model);
    assert_ne!(exact_lm.landmarks, a.landmarks);
    // Landmark noise: about 1 mm per coordinate around the model's landmarks.
    let exact: Vec<Vec<[f64; 3]>> = (0..4)
        .map(|t| qcshape_studies::lv::anatomy::landmarks(&a.model, t as f64))
        .collect();
    let mut sq = 0.0;
    let mut count = 0.0;
    for (f, g) in a.landmarks.frames.iter().zip(&exact) {
        for (p, q) in f.iter().zip(g) {
            for k in 0..3 {
                sq += (p[k] - q[k]).powi(2);
                count += 1.0;
            }
        }
    }
    let rms = (sq / count).sqrt();
    assert!((0.8..1.2).contains(&rms), "landmark noise rms {rms} mm");
    // The heart stays inside the field of view: every border voxel is background.
    for i in 0..6 {
        let s = subject(
            "s",
            if i % 2 == 0 { Group::Hcm } else { Group::Control },
            i,
            &opts,
        );
        let v = &s.frames[0];
        let [nx, ny, nz] = v.dims;
        for z in 0..nz {
            for y in 0..ny {
                for x in [0, nx - 1] {
                    assert!(
                        v.data[v.index(x, y, z)] < -300.0,
                        "subject {i}: tissue at the border"
                    );
                }
            }
        }
    }
    // Tilts up to 25 degrees (the default cohort: 6), and overlapping parameter ranges.
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut tilt_max = 0.0f64;
    let mut range = |group: Group, rng: &mut ChaCha8Rng| {
        let mut lo = [f64::MAX; 4];
        let mut hi = [f64::MIN; 4];
        for _ in 0..300 {
            let mut m = sample_model(group, 8, rng);
            overlap_model(&mut m, group, rng);
            tilt_max = tilt_max.max(m.rotation[2][2].acos().to_degrees());
            let x = [
                m.free_wall,
                m.long_strain,
                m.circ_strain * m.free_wall_motion,
                m.twist_apex_deg - m.twist_base_deg,
            ];
            for k in 0..4 {
                lo[k] = lo[k].min(x[k]);
                hi[k] = hi[k].max(x[k]);
            }
        }
        (lo, hi)
    };
    let (c_lo, c_hi) = range(Group::Control, &mut rng);
    let (h_lo, h_hi) = range(Group::Hcm, &mut rng);
    for k in 0..4 {
        assert!(
            h_lo[k] < c_hi[k] && c_lo[k] < h_hi[k],
            "parameter {k}: control {}..{}, HCM {}..{} do not overlap",
            c_lo[k],
            c_hi[k],
            h_lo[k],
            h_hi[k]
        );
    }
    assert!((20.0..25.0).contains(&tilt_max), "largest tilt {tilt_max}");
}

fn write_cohort(dir: &std::path::Path, controls: usize, hcm: usize, opts: &PhantomOptions) {
    let names = roster(controls, hcm, opts.seed);
    for (i, (name, group)) in names.iter().enumerate() {
        let s = subject(name, *group, i as u64, opts);
        write_subject(dir, &s, false).unwrap();
    }
    let labels: Vec<(String, Option<String>)> = names
        .iter()
        .map(|(n, g)| (n.clone(), Some(g.label().to_string())))
        .collect();
    write_labels(&dir.join(LABELS_NAME), &labels).unwrap();
}

fn rotation_z(angle: f64) -> Motion {
    let (s, c) = angle.sin_cos();
    Motion {
        rotation: [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
        scale: 1.0,
        translation: [3.0, -2.0, 1.0],
    }
}

#[test]
fn cohort_study_structs_are_consistent_and_rigid_alignment_removes_a_subjects_pose() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("cohort");
    let popts = PhantomOptions {
        size: 24,
        frames: 4,
        seed: 2,
        ..Default::default()
    };
    write_cohort(&dir, 2, 2, &popts);
    assert!(is_cohort(&dir));
    let ticks = std::sync::atomic::AtomicUsize::new(0);
    let progress = |t: Tick<'_>| {
        if !t.what.is_empty() {
            ticks.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
    };
    let mesh = MeshSettings {
        threshold: None,
        smooth: 10,
        vertices: 120,
        free_wall: true,
        sector: Default::default(),
        tps_lambda: 0.0,
        harmonics: None,
        refine: None,
    };
    let c = mesh_cohort(&dir, 16, &mesh, &progress).unwrap();
    assert_eq!(c.defs.len(), 4);
    assert_eq!(ticks.load(std::sync::atomic::Ordering::Relaxed), 4);
    let nv = c.defs[0].topology.n_vertices();
    assert!(c
        .defs
        .iter()
        .all(|d| d.poses.len() == 4 && d.poses[0].len() == nv));
    let opts = PipelineOptions {
        geodesic: GeodesicOptions {
            steps: 2,
            ..Default::default()
        },
        insert: 1,
        levels: 1,
        transport: Transport::Parallel,
        base: 0,
        align: Alignment::Rigid,
        ..Default::default()
    };
    let split = SplitOptions {
        method: ClusterMethod::KernelKMeans,
        restarts: 5,
        seed: 0,
    };
    let main = analyse(&c.defs, &opts, false, &split, &progress).unwrap();
    let n = 4;
    assert_eq!(main.matrix.len(), n);
    for i in 0..n {
        assert_eq!(main.matrix.get(i, i), 0.0);
        for j in 0..n {
            assert_eq!(main.matrix.get(i, j), main.matrix.get(j, i));
            if i != j {
                assert!(main.matrix.get(i, j) > 0.0);
            }
        }
    }
    // 4 frames, closed, 1 inserted pose per gap: 8 poses, 4 of them keys.
    assert_eq!(main.prepared.is_key.len(), 8);
    assert_eq!(main.prepared.is_key.iter().filter(|&&k| k).count(), 4);
    let s = &main.scores;
    let [tp, fn_, fp, tn] = s.counts;
    assert_eq!(tp + fn_ + fp + tn, n as f64);
    assert_eq!(tp + fn_, 2.0);
    assert!((s.sensitivity - tp / (tp + fn_)).abs() < 1e-12);
    assert!((s.specificity - tn / (tn + fp)).abs() < 1e-12);
    assert_eq!(s.positive, "hcm");
    assert_eq!(main.clustering.assignments.len(), n);
    assert_eq!(main.pair_seconds.len(), n * (n - 1) / 2);
    let base = baselines(&c.defs, &c.axes, false, &split).unwrap();
    assert_eq!(base.rows.len(), 2);
    assert!(base.rows[0].values.iter().all(|&v| v > 0.0 && v.is_finite()));
    assert_eq!(base.ed_es.len(), n);
    let labels = labels_of(&c.defs).unwrap();
    let methods = [
        ClusterMethod::KernelKMeans,
        ClusterMethod::KMedoids,
        ClusterMethod::Spectral { scale: 1.0 },
    ];
    let rows = compare_methods(&main, &opts, &base, &labels, &methods, &split).unwrap();
    assert_eq!(rows.len(), 3 * methods.len());
    assert_eq!(rows[0].data, "similarity");
    assert_eq!(rows[0].scores, main.scores, "the kmeans row is the main split");
    assert_eq!(rows[3].scores.sensitivity, base.rows[0].scores.sensitivity);
    // The structs serialize.
    let json = serde_json::to_string(&main).unwrap();
    assert!(json.contains("\"sensitivity\""));

    // Move one subject rigidly: with alignment the matrix is the same (to solver tolerance),
    // without it the matrix changes.
    let mut moved = c.defs.clone();
    let m = rotation_z(1.3);
    for p in &mut moved[2].poses {
        p.iter_mut().for_each(|v| *v = m.apply(*v));
    }
    let again = analyse(&moved, &opts, false, &split, &progress).unwrap();
    let scale = main.matrix.values().iter().cloned().fold(0.0, f64::max);
    for (a, b) in again.matrix.values().iter().zip(main.matrix.values()) {
        assert!((a - b).abs() < 1e-3 * scale, "aligned: {a} vs {b}");
    }
    let none = PipelineOptions {
        align: Alignment::None,
        ..opts.clone()
    };
    let unaligned = analyse(&c.defs, &none, false, &split, &progress).unwrap();
    let posed = analyse(&moved, &none, false, &split, &progress).unwrap();
    let worst = posed
        .matrix
        .values()
        .iter()
        .zip(unaligned.matrix.values())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst > 1e-2 * scale, "without alignment the pose shows: {worst}");
}

/// Root-mean-square distance (mm) between corresponding vertices of every pose of two meshed
/// cohorts on one connectivity.
fn cohort_rms(a: &MeshedCohort, b: &MeshedCohort) -> f64 {
    let (mut sum, mut n) = (0.0, 0.0);
    for (da, db) in a.defs.iter().zip(&b.defs) {
        for (pa, pb) in da.poses.iter().zip(&db.poses) {
            for (u, v) in pa.iter().zip(pb) {
                sum += (0..3).map(|c| (u[c] - v[c]).powi(2)).sum::<f64>();
                n += 1.0;
            }
        }
    }
    (sum / n).sqrt()
}

#[test]
fn low_passed_landmarks_bring_noisy_cohort_meshes_closer_to_the_noise_free_ones() {
    let tmp = tempfile::tempdir().unwrap();
    let popts = |noise: f64| PhantomOptions {
        size: 24,
        frames: 8,
        seed: 5,
        landmark_noise_mm: noise,
        ..Default::default()
    };
    // The same subjects (the landmark noise has its own random stream), without and with noise.
    let (clean_dir, noisy_dir) = (tmp.path().join("clean"), tmp.path().join("noisy"));
    write_cohort(&clean_dir, 2, 1, &popts(0.0));
    write_cohort(&noisy_dir, 2, 1, &popts(1.0));
    let settings = |harmonics: Option<usize>| MeshSettings {
        threshold: None,
        smooth: 10,
        vertices: 150,
        free_wall: false,
        sector: Default::default(),
        tps_lambda: 0.0,
        harmonics,
        refine: None,
    };
    let none = |_: Tick<'_>| {};
    let clean = mesh_cohort(&clean_dir, 16, &settings(None), &none).unwrap();
    let raw = mesh_cohort(&noisy_dir, 16, &settings(None), &none).unwrap();
    let filtered = mesh_cohort(&noisy_dir, 16, &settings(Some(2)), &none).unwrap();
    let (e_raw, e_filtered) = (cohort_rms(&raw, &clean), cohort_rms(&filtered, &clean));
    // Measured: 1.39 mm raw, 1.09 mm filtered (independent noise keeps sqrt(5/8) = 0.79 of its
    // size with harmonics 0-2 of 8 frames); the filter bends the true motion by 0.19 mm (the
    // clean cohort filtered against the clean one).
    assert!(e_raw > 0.5, "the landmark noise must reach the meshes: {e_raw}");
    assert!(
        e_filtered < 0.85 * e_raw,
        "filtered {e_filtered} mm vs raw {e_raw} mm"
    );
    let bias = cohort_rms(
        &mesh_cohort(&clean_dir, 16, &settings(Some(2)), &none).unwrap(),
        &clean,
    );
    assert!(
        bias < 0.5 * e_filtered,
        "the filter bends the clean motion by {bias} mm"
    );
}

#[test]
fn image_refinement_brings_carried_meshes_onto_the_true_cavity_wall() {
    let tmp = tempfile::tempdir().unwrap();
    let opts = PhantomOptions {
        size: 32,
        frames: 8,
        seed: 5,
        landmark_noise_mm: 1.0,
        ..Default::default()
    };
    let dir = tmp.path().join("noisy");
    write_cohort(&dir, 2, 1, &opts);
    let names = roster(2, 1, opts.seed);
    let models: Vec<_> = names
        .iter()
        .enumerate()
        .map(|(i, (name, group))| subject(name, *group, i as u64, &opts).model)
        .collect();
    let settings = |refine: Option<f64>| MeshSettings {
        threshold: None,
        smooth: 10,
        vertices: 300,
        free_wall: false,
        sector: Default::default(),
        tps_lambda: 0.0,
        harmonics: Some(2),
        refine,
    };
    let none = |_: Tick<'_>| {};
    // Root mean square distance (mm) of every vertex of every frame to the true wall.
    let off_wall = |c: &MeshedCohort| {
        let (mut sum, mut n) = (0.0, 0.0);
        for (d, m) in c.defs.iter().zip(&models) {
            for (t, pose) in d.poses.iter().enumerate() {
                for &p in pose {
                    sum += m.cavity_distance(p, t as f64).powi(2);
                    n += 1.0;
                }
            }
        }
        (sum / n).sqrt()
    };
    let carried = mesh_cohort(&dir, 16, &settings(None), &none).unwrap();
    let refined = mesh_cohort(&dir, 16, &settings(Some(4.0)), &none).unwrap();
    // Refinement needs an image per landmark frame: a missing one is an error naming the subject.
    let short = tmp.path().join("short");
    write_cohort(&short, 2, 1, &opts);
    std::fs::remove_file(short.join(&names[1].0).join("frame07.nii.gz")).unwrap();
    let e = mesh_cohort(&short, 16, &settings(Some(4.0)), &none)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(&names[1].0) && e.contains("7 image frames but 8 landmark frames"),
        "{e}"
    );
    let (e_carried, e_refined) = (off_wall(&carried), off_wall(&refined));
    // Measured: 1.54 mm carried, 0.65 mm refined (32³ voxels of 3.3 x 3.3 x 4.1 mm).
    assert_eq!(refined.refined.0, 3 * 8, "every frame is refined");
    assert_eq!(carried.refined.0, 0);
    assert!(
        e_carried > 0.5,
        "the landmark noise must reach the meshes: {e_carried}"
    );
    assert!(
        e_refined < 0.5 * e_carried,
        "refined {e_refined} mm vs carried {e_carried} mm off the true wall"
    );
}
