//! `cosim-server bench accuracy --quick`: the files it writes, and the
//! physics its numbers must show (issue #6).

use std::collections::HashMap;
use std::path::PathBuf;
use std::process::Command;

fn out_dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("cosim-bench-accuracy-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn quick_sweep_writes_csv_and_diagrams_with_the_expected_errors() {
    let dir = out_dir();
    let out = Command::new(env!("CARGO_BIN_EXE_cosim-server"))
        .args(["bench", "accuracy", "--quick", "--out"])
        .arg(&dir)
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let csv = std::fs::read_to_string(dir.join("accuracy.csv")).expect("accuracy.csv");
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let (c_setting, c_case, c_h, c_err, c_fail, c_metrics) = (
        col("setting"),
        col("case"),
        col("h"),
        col("error"),
        col("failure"),
        col("metrics"),
    );
    // (case, setting, h) -> (error, metrics)
    let mut table = HashMap::new();
    for l in lines {
        // error_name is quoted and contains no comma; split is safe.
        let f: Vec<&str> = l.split(',').collect();
        assert_eq!(f.len(), header.len(), "{l}");
        assert_eq!(f[c_fail], "", "a run failed: {l}");
        let h: f64 = f[c_h].parse().expect("h");
        let err: f64 = f[c_err].parse().expect("error");
        table.insert(
            (
                f[c_case].to_string(),
                f[c_setting].to_string(),
                (h * 1e4).round() as i64,
            ),
            (err, f[c_metrics].to_string()),
        );
    }
    let get = |case: &str, setting: &str, h: f64| {
        table
            .get(&(
                case.to_string(),
                setting.to_string(),
                (h * 1e4).round() as i64,
            ))
            .unwrap_or_else(|| panic!("no row {case} {setting} {h}"))
            .clone()
    };
    let metric = |m: &str, name: &str| -> f64 {
        m.split(';')
            .find_map(|kv| kv.strip_prefix(&format!("{name}=")))
            .unwrap_or_else(|| panic!("{name} in {m}"))
            .parse()
            .expect("number")
    };
    for s in ["lemke nd=8", "pgs tol=1e-6"] {
        // S1: semi-implicit Euler is first order: the distance error is
        // d h / t exactly (1.7518 mm at h = 1e-3), a tenth per decade of h.
        let (e2, _) = get("S1", s, 1e-2);
        let (e3, m3) = get("S1", s, 1e-3);
        assert!((e3 - 1.7518e-3).abs() < 2e-5, "S1 {s}: {e3}");
        assert!((e2 / e3 - 10.0).abs() < 0.1, "S1 {s}: ratio {}", e2 / e3);
        assert!(metric(&m3, "slip_m") < 1e-9, "S1 {s} slips: {m3}");
        // S2: constant friction then rolling: the velocity update is exact.
        assert!(get("S2", s, 1e-3).0 < 1e-9, "S2 {s}");
        // S3: the apex error falls with h.
        assert!(get("S3", s, 1e-3).0 < 1e-3, "S3 {s}");
        // S6: exact static equilibrium, no jitter.
        let (e6, m6) = get("S6", s, 1e-3);
        assert!(e6 < 1e-6, "S6 {s}: {e6}");
        assert!(metric(&m6, "force_std_n") < 1e-6, "S6 {s}: {m6}");
        // The reference scene converges.
        assert!(get("REF", s, 1e-3).0 < get("REF", s, 1e-2).0, "REF {s}");
    }
    // The trapezoid position update makes S1 exact (constant acceleration)
    // and leaves S2 exact, at any h.
    for h in [1e-2, 1e-3] {
        let (e, m) = get("S1", "lemke nd=8 trapezoid", h);
        assert!(e < 1e-12, "S1 trapezoid at h = {h}: {e}");
        assert!(metric(&m, "slip_m") < 1e-9, "S1 trapezoid slips: {m}");
        assert!(
            get("S2", "lemke nd=8 trapezoid", h).0 < 1e-9,
            "S2 trapezoid"
        );
    }
    // S4 (Lemke, h = 1e-3): energy within 1 %, joints within 1 mm.
    let (e4, m4) = get("S4", "lemke nd=8", 1e-3);
    assert!(e4 < 1e-2, "S4 energy drift {e4}");
    assert!(metric(&m4, "joint_error_m") < 1e-3, "S4: {m4}");
    // S7, the hinge chain of capsules (h = 1e-3): energy within 2 %,
    // joints within 1 mm, axes kept (the hinge's rows hold them).
    for s in ["lemke nd=8", "pgs tol=1e-6"] {
        let (e7, m7) = get("S7", s, 1e-3);
        assert!(e7 < 2e-2, "S7 {s}: energy drift {e7}");
        assert!(metric(&m7, "joint_error_m") < 1e-3, "S7 {s}: {m7}");
        assert!(metric(&m7, "axis_error_rad") < 1e-3, "S7 {s}: {m7}");
    }
    // S4 and S7 are scored on their largest energy drift over the run,
    // which bounds the end point's; their positions at 1 s converge at
    // first order against the extrapolated reference (measured: 8.9 and
    // 5.0 times closer from h = 1e-2 to 1e-3).
    for case in ["S4", "S7"] {
        for s in ["lemke nd=8", "pgs tol=1e-6"] {
            let (max2, m2) = get(case, s, 1e-2);
            let (max3, m3) = get(case, s, 1e-3);
            for (max, m) in [(max2, &m2), (max3, &m3)] {
                assert!(metric(m, "end_energy_drift") <= max, "{case} {s}: {m}");
            }
            let (p2, p3) = (
                metric(&m2, "position_error_1s_m"),
                metric(&m3, "position_error_1s_m"),
            );
            assert!(
                (4.0..15.0).contains(&(p2 / p3)),
                "{case} {s}: position error at 1 s {p2} at h = 1e-2, {p3} at 1e-3"
            );
        }
    }
    // S8, the box sliding to rest: each Euler step takes a h off the speed
    // exactly, so the distance is the discrete sum (v0 h / 2 short of the
    // continuous answer); the trapezoid update leaves only the last
    // step's part (below a h^2); no pitch, no sink.
    for h in [1e-2, 1e-3] {
        let discrete = cosim_bench::cases::incline_discrete_distance(h);
        let exact = cosim_bench::cases::incline_stop_distance();
        for s in ["lemke nd=8", "pgs tol=1e-6"] {
            let (e8, m8) = get("S8", s, h);
            let d = metric(&m8, "distance_m");
            assert!(
                (d - discrete).abs() < 1e-9,
                "S8 {s} h={h}: {d} not {discrete}"
            );
            assert!((e8 - (exact - discrete)).abs() < 1e-9, "S8 {s}: {e8}");
            assert!(metric(&m8, "pitch_rad") < 1e-6, "S8 {s}: {m8}");
            assert!(metric(&m8, "sink_m") < 1e-7, "S8 {s}: {m8}");
        }
        let (e8, _) = get("S8", "lemke nd=8 trapezoid", h);
        let a = cosim_bench::cases::incline_deceleration();
        assert!(e8 < a * h * h, "S8 trapezoid at h = {h}: {e8}");
    }
    for case in ["S1", "S2", "S3", "S4", "S6", "S7", "S8", "REF"] {
        let png = dir.join(format!("accuracy-{case}.png"));
        let img = image::open(&png).unwrap_or_else(|e| panic!("{}: {e}", png.display()));
        assert_eq!((img.width(), img.height()), (1000, 720));
    }
    let _ = std::fs::remove_dir_all(&dir);
}
