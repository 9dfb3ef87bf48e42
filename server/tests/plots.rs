//! Figures and animation: every file exists and decodes, text renders from
//! the embedded font, the GIF has the expected frames and follows the
//! trajectory, and drawing is deterministic.

use cosim_figures::animation::{frames, marker, Camera};
use cosim_figures::{color, data::RunData};
use cosim_server::engine::Model;
use cosim_shared::Scene;
use image::AnimationDecoder;
mod common;

use common::TempDir;
use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_cosim-server");

/// Every figure the reference scene draws: it has joints and friction,
/// so all of them but the hinges' and sliders' coordinates (it has
/// neither: `slider.toml` draws that one, below).
fn figures() -> Vec<&'static str> {
    let all = cosim_figures::figures::STEMS;
    all.into_iter()
        .filter(|&f| f != "joint_coordinates")
        .collect()
}
fn run_plot(out: &Path) {
    let status = Command::new(BIN)
        .args([
            "run",
            "--steps",
            "700",
            "--plot",
            "--animate",
            "--quiet",
            "--out",
        ])
        .arg(out)
        .status()
        .expect("run");
    assert!(status.success());
}

fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = figures()
        .iter()
        .flat_map(|f| {
            [
                dir.join("plots").join(format!("{f}.png")),
                dir.join("plots").join(format!("{f}.svg")),
            ]
        })
        .collect();
    v.push(dir.join("animation.gif"));
    v
}

#[test]
fn figures_and_animation_decode_follow_the_trajectory_and_repeat() {
    let tmp = TempDir::new("plots-all");
    let a = tmp.path().join("a");
    run_plot(&a);

    for f in figures() {
        let png = image::open(a.join("plots").join(format!("{f}.png")))
            .expect("PNG decodes")
            .to_rgb8();
        // The title is text in the top band: dark pixels there prove the
        // embedded font rendered.
        let dark = (0..png.width())
            .flat_map(|x| (0..36).map(move |y| (x, y)))
            .filter(|&(x, y)| png.get_pixel(x, y).0.iter().all(|&c| c < 80))
            .count();
        assert!(dark > 100, "{f}: no title text ({dark} dark pixels)");
        let svg = std::fs::read_to_string(a.join("plots").join(format!("{f}.svg"))).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("t (s)"), "{f}.svg");
    }

    // The GIF: one frame per 40 ms of simulated time, 0.7 s -> 18 frames.
    let gif = std::fs::File::open(a.join("animation.gif")).unwrap();
    let decoded: Vec<image::Frame> =
        image::codecs::gif::GifDecoder::new(std::io::BufReader::new(gif))
            .expect("GIF decodes")
            .into_frames()
            .collect::<Result<_, _>>()
            .expect("frames decode");
    let run = RunData::load(&a).unwrap();
    let (shown, delay) = frames(&run);
    assert_eq!(delay, 40);
    assert_eq!(decoded.len(), shown.len());
    assert_eq!(decoded.len(), 18);

    // In a frame where the discs are apart and the marker is off-centre, the
    // pixels around each sphere's projected centre have that sphere's
    // colour (most of eight at half its radius: the joint links, drawn
    // over the spheres, and the highlight may cover a few).
    let scene = Scene::load(&a.join("scene.toml")).unwrap();
    let model = Model::from_scene(&scene);
    let cam = Camera::frame(&model, scene.camera.as_ref(), &run);
    let centre = |b: usize, i: usize| {
        let r = run.bodies[b].rows[i];
        nalgebra::Vector3::new(r[0], r[1], r[2])
    };
    let mut checked = 0;
    for (k, &i) in shown.iter().enumerate() {
        let (pa, pb) = (cam.project(&centre(0, i)), cam.project(&centre(1, i)));
        let gap = ((pa.0 - pb.0).powi(2) + (pa.1 - pb.1).powi(2)).sqrt();
        let radii: Vec<f64> = model.bodies.iter().map(|body| body.bound).collect();
        if gap < (radii[0] + radii[1]) * cam.scale + 2.0 {
            continue;
        }
        for (b, &radius) in radii.iter().enumerate() {
            let (cx, cy) = cam.project(&centre(b, i));
            let shape = &model.bodies[b].shapes[0].shape;
            let (mx, my) = cam.project(&marker(shape, &run.bodies[b].rows[i]));
            if ((mx - cx).powi(2) + (my - cy).powi(2)).sqrt() < 0.3 * radius * cam.scale {
                continue;
            }
            let want = color(b);
            let rp = radius * cam.scale;
            let near = (0..8)
                .filter(|n| {
                    let a = std::f64::consts::PI / 4.0 * *n as f64;
                    let (sx, sy) = (cx + 0.5 * rp * a.cos(), cy + 0.5 * rp * a.sin());
                    let px = decoded[k]
                        .buffer()
                        .get_pixel(sx.round() as u32, sy.round() as u32)
                        .0;
                    [
                        px[0] as i32 - want.0 as i32,
                        px[1] as i32 - want.1 as i32,
                        px[2] as i32 - want.2 as i32,
                    ]
                    .iter()
                    .all(|d| d.abs() <= 24)
                })
                .count();
            assert!(
                near >= 5,
                "frame {k}, body {b}: {near} of 8 pixels around the centre in its colour {want:?}"
            );
            checked += 1;
        }
    }
    assert!(checked >= 10, "only {checked} checks possible");

    // Drawing again, from the files alone, gives the same bytes.
    let status = Command::new(BIN).arg("plot").arg(&a).status().unwrap();
    assert!(status.success());
    let b = tmp.path().join("b");
    run_plot(&b);
    // The timings figure draws this run's wall times: not repeatable.
    let repeatable = |f: &PathBuf| !f.to_string_lossy().contains("timings.");
    for (fa, fb) in files(&a)
        .iter()
        .zip(files(&b))
        .filter(|(fa, _)| repeatable(fa))
    {
        assert_eq!(
            std::fs::read(fa).unwrap(),
            std::fs::read(&fb).unwrap(),
            "{} differs",
            fa.display()
        );
    }
}

#[test]
fn plotting_a_folder_without_a_run_exits_2() {
    let tmp = TempDir::new("plots-empty");
    let out = Command::new(BIN)
        .arg("plot")
        .arg(tmp.path())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("states.csv"));
}

/// The pixels of `png` within `tol` of colour `c` in every channel.
fn pixels_of(png: &image::RgbImage, c: cosim_figures::RGBColor, tol: i32) -> Vec<(u32, u32)> {
    png.enumerate_pixels()
        .filter(|(_, _, p)| {
            (p.0[0] as i32 - c.0 as i32).abs() <= tol
                && (p.0[1] as i32 - c.1 as i32).abs() <= tol
                && (p.0[2] as i32 - c.2 as i32).abs() <= tol
        })
        .map(|(x, y, _)| (x, y))
        .collect()
}

/// The 8-connected groups of `pixels`, largest first.
fn components(pixels: &[(u32, u32)]) -> Vec<Vec<(u32, u32)>> {
    let set: std::collections::HashSet<(u32, u32)> = pixels.iter().copied().collect();
    let mut seen = std::collections::HashSet::new();
    let mut out = Vec::new();
    for &p in pixels {
        if !seen.insert(p) {
            continue;
        }
        let mut group = vec![p];
        let mut stack = vec![p];
        while let Some((x, y)) = stack.pop() {
            for dx in -1i64..=1 {
                for dy in -1i64..=1 {
                    let q = ((x as i64 + dx) as u32, (y as i64 + dy) as u32);
                    if set.contains(&q) && seen.insert(q) {
                        group.push(q);
                        stack.push(q);
                    }
                }
            }
        }
        out.push(group);
    }
    out.sort_by_key(|g| std::cmp::Reverse(g.len()));
    out
}

/// Issue 16, point 1: the PNGs drew the data wrongly (plotters issue 549:
/// lines wider than a pixel leave their panel, steep segments come out
/// dotted, a spike shows as a piece and a lone dot). A known series is
/// drawn and the PNG's pixels checked: the line is one connected piece
/// that reaches the spike's top, stays in its own panel and right of the
/// tick labels, and spans the time axis.
#[test]
fn a_known_series_is_drawn_where_it_must_be_and_nowhere_else() {
    use cosim_figures::chart::{figure, Frame, Panel, Series};
    let tmp = TempDir::new("plots-pixels");
    // A baseline at 0, a one-sample spike to 10 at t = 1.5, a step to 1
    // at t = 1.8 (the shape of an impact on a resting contact).
    // Three samples a pixel, as a 3 s run at h = 1e-3 has.
    let spike: Vec<(f64, f64)> = (0..=3000)
        .map(|k| {
            let t = k as f64 * 1e-3;
            let y = match k {
                1500 => 10.0,
                k if k >= 1800 => 1.0,
                _ => 0.0,
            };
            (t, y)
        })
        .collect();
    let flat: Vec<(f64, f64)> = spike.iter().map(|&(t, _)| (t, -3.0)).collect();
    let panels = [
        Panel::new(
            "spike",
            vec![Series {
                name: "s".into(),
                color: color(0),
                points: spike,
                thin: false,
            }],
        ),
        Panel::new(
            "flat",
            vec![Series {
                name: "f".into(),
                color: color(1),
                points: flat,
                thin: false,
            }],
        ),
    ];
    let frame = Frame {
        t: Some((0.0, 3.0)),
        ..Frame::default()
    };
    let files = figure(tmp.path(), "known", "known series", &frame, &panels).expect("drawn");
    let png = image::open(&files[0]).expect("PNG decodes").to_rgb8();
    let (w, h) = png.dimensions();
    let s = pixels_of(&png, color(0), 30);
    let groups = components(&s);
    // The series and the legend's sample: nothing else of its colour.
    assert!(
        groups.len() <= 2,
        "{} pieces of the series' colour: {:?}",
        groups.len(),
        groups.iter().map(|g| (g.len(), g[0])).collect::<Vec<_>>()
    );
    let line = &groups[0];
    let (xs, ys): (Vec<u32>, Vec<u32>) = line.iter().copied().unzip();
    let (x_lo, x_hi) = (*xs.iter().min().unwrap(), *xs.iter().max().unwrap());
    let (y_lo, y_hi) = (*ys.iter().min().unwrap(), *ys.iter().max().unwrap());
    // Right of the y tick labels (margin 10 + label area 80), inside the
    // top panel (the figure's lower half is the second panel).
    assert!(x_lo >= 90 && x_hi < w, "x {x_lo}..{x_hi}");
    assert!(
        y_hi < h / 2,
        "the line reaches y = {y_hi}, into the lower panel"
    );
    // Spanning the time axis: from the left of the plot to its right.
    assert!(x_hi - x_lo > (w - 110) * 8 / 10, "x {x_lo}..{x_hi}");
    // The spike's full height: the data span 0..10 is 1 / 1.12 of the
    // plot's height (6 % padding each side), about 250 of the panel's
    // 340 pixels less its margins and axis area.
    assert!(y_hi - y_lo > 200, "the line spans y {y_lo}..{y_hi} only");
    // The flat series: one straight run in the lower panel.
    let f = components(&pixels_of(&png, color(1), 30));
    let (_, fy): (Vec<u32>, Vec<u32>) = f[0].iter().copied().unzip();
    assert!(
        fy.iter().all(|&y| y > h / 2),
        "the flat line leaves its panel"
    );
}

/// Issue 16, point 3: a group with nothing in it is not drawn (no joints,
/// no friction), and a failed run's figures are marked at the failed step.
#[test]
fn figures_leave_out_empty_groups_and_mark_a_failure() {
    let tmp = TempDir::new("plots-groups");
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes");
    let out = tmp.path().join("frictionless");
    let status = Command::new(BIN)
        .arg("run")
        .arg(scenes.join("frictionless.toml"))
        .args(["--steps", "300", "--plot", "--quiet", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let plots = out.join("plots");
    assert!(plots.join("normal_forces.png").exists());
    assert!(!plots.join("friction_forces.png").exists());
    assert!(!plots.join("joint_forces.png").exists());
    assert!(!plots.join("joint_angles.png").exists());
    assert!(!plots.join("joint_coordinates.png").exists());

    // The reference scene with a force that overflows the first step.
    let text = std::fs::read_to_string(scenes.join("reference.toml")).unwrap();
    let text = text.replacen(
        "velocity = [0.0, -1.5, 0.0]",
        "velocity = [0.0, -1.5, 0.0]\nforce = [0.0, 0.0, 1e306]",
        1,
    );
    let scene = tmp.path().join("overflow.toml");
    std::fs::write(&scene, text).unwrap();
    let out = tmp.path().join("overflow");
    let status = Command::new(BIN)
        .arg("run")
        .arg(&scene)
        .args(["--plot", "--animate", "--quiet", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert_eq!(status.code(), Some(1), "the run fails");
    // The animation's frame of the failed state carries the banner: a red
    // band across the bottom.
    let gif = std::fs::File::open(out.join("animation.gif")).unwrap();
    let frames: Vec<image::Frame> =
        image::codecs::gif::GifDecoder::new(std::io::BufReader::new(gif))
            .unwrap()
            .into_frames()
            .collect::<Result<_, _>>()
            .unwrap();
    let last = frames.last().unwrap().buffer();
    let banner = (0..last.width())
        .filter(|&x| {
            let p = last.get_pixel(x, last.height() - 4).0;
            p[0] > 150 && p[1] < 60 && p[2] < 60
        })
        .count();
    assert!(
        banner > last.width() as usize * 9 / 10,
        "{banner} red pixels"
    );
    let png = image::open(out.join("plots/positions.png"))
        .unwrap()
        .to_rgb8();
    let red = pixels_of(&png, cosim_figures::RGBColor(200, 0, 0), 10);
    // A marker line down each of the three panels.
    assert!(red.len() > 3 * 200, "{} marker pixels", red.len());
}

/// Issue 16, point 5: `plot A B` draws two runs in the same figures (the
/// second thin over the first, both named in the legend and subtitle),
/// `--only` chooses figures, `--from`/`--to` a time window, `--size` the
/// image; a figure name that does not exist is named in the error.
#[test]
fn two_runs_overlay_in_the_chosen_figures_and_window() {
    let tmp = TempDir::new("plots-overlay");
    let (a, b) = (tmp.path().join("lemke"), tmp.path().join("pgs"));
    for (dir, solver) in [(&a, "lemke"), (&b, "pgs")] {
        let status = Command::new(BIN)
            .args([
                "run", "--steps", "400", "--quiet", "--solver", solver, "--out",
            ])
            .arg(dir)
            .status()
            .unwrap();
        assert!(status.success());
    }
    let out = tmp.path().join("cmp");
    let status = Command::new(BIN)
        .arg("plot")
        .arg(&a)
        .arg(&b)
        .args([
            "--only",
            "velocities,energy",
            "--from",
            "0.1",
            "--to",
            "0.3",
            "--size",
            "1300x800",
            "--out",
        ])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "energy.png",
            "energy.svg",
            "velocities.png",
            "velocities.svg"
        ]
    );
    let png = image::open(out.join("velocities.png")).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (1300, 800));
    let svg = std::fs::read_to_string(out.join("energy.svg")).unwrap();
    for label in ["total (lemke)", "total (pgs)", "solver lemke", "solver pgs"] {
        assert!(svg.contains(label), "{label} missing");
    }
    // The window: the time axis starts at 0.1 and ends at 0.3 (the SVG
    // has each text on a line of its own).
    let texts: Vec<&str> = svg.lines().map(str::trim).collect();
    assert!(texts.contains(&"0.1") && texts.contains(&"0.3"));
    assert!(!texts.contains(&"0.4") && !texts.contains(&"0.05"));

    // --bodies: only those bodies and their contacts.
    let status = Command::new(BIN)
        .arg("plot")
        .arg(&a)
        .args(["--bodies", "lower", "--only", "positions,normal_forces"])
        .status()
        .unwrap();
    assert!(status.success());
    // A subset goes beside the run's own figures (issue 46: a window
    // drew over them), into A/focus/.
    assert!(!a.join("plots").exists());
    let texts = |f: &str| {
        std::fs::read_to_string(a.join("focus").join("plots").join(f))
            .unwrap()
            .lines()
            .map(|l| l.trim().to_string())
            .collect::<Vec<_>>()
    };
    let positions = texts("positions.svg");
    assert!(positions.contains(&"lower".to_string()) && !positions.contains(&"upper".to_string()));
    let forces = texts("normal_forces.svg");
    assert!(forces.contains(&"lower/floor".to_string()));
    assert!(!forces.iter().any(|t| t == "upper/wall_y"), "{forces:?}");
    // --per-contact: a panel per contact (default height: 260 a panel).
    let status = Command::new(BIN)
        .arg("plot")
        .arg(&a)
        .args(["--per-contact", "--only", "normal_forces"])
        .status()
        .unwrap();
    assert!(status.success());
    let csv = std::fs::read_to_string(a.join("impulses.csv")).unwrap();
    let mut contacts: Vec<&str> = csv
        .lines()
        .filter_map(|l| l.split(',').nth(3).filter(|_| l.contains(",normal,")))
        .collect();
    contacts.sort();
    contacts.dedup();
    assert!(contacts.len() >= 2, "{contacts:?}");
    let png = image::open(a.join("focus/plots/normal_forces.png")).unwrap();
    assert_eq!(png.height(), 200 + 260 * contacts.len() as u32);
    let unknown = Command::new(BIN)
        .arg("plot")
        .arg(&a)
        .args(["--bodies", "nobody"])
        .output()
        .unwrap();
    assert_eq!(unknown.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&unknown.stderr).contains("upper, lower"));

    let bad = Command::new(BIN)
        .arg("plot")
        .arg(&a)
        .args(["--only", "velocity"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("\"velocity\"") && err.contains("velocities"),
        "{err}"
    );
}

/// A scene with a hinge and a slider draws their coordinates from
/// joints.csv (the panels' data: `joint_coordinates_draw_a_turning_hinge_
/// unwrapped_and_a_slider_in_metres` in figures.rs), and a run without
/// joints.csv (a recording) still draws the rest.
#[test]
fn a_hinge_and_a_slider_draw_their_coordinates() {
    let tmp = TempDir::new("plots-coordinates");
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/scenes");
    let out = tmp.path().join("slider");
    let status = Command::new(BIN)
        .arg("run")
        .arg(scenes.join("slider.toml"))
        .args(["--steps", "800", "--plot", "--quiet", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let png = out.join("plots").join("joint_coordinates.png");
    let image = image::open(&png).expect("PNG decodes").to_rgb8();
    // Four panels (hinge angle and rate, slider offset and speed): 260
    // pixels each (`Options::size`).
    assert!(image.height() >= 4 * 260, "{} pixels high", image.height());
    std::fs::remove_file(out.join("joints.csv")).unwrap();
    std::fs::remove_dir_all(out.join("plots")).unwrap();
    let status = Command::new(BIN).arg("plot").arg(&out).status().unwrap();
    assert!(status.success());
    assert!(out.join("plots").join("positions.png").exists());
    assert!(!out.join("plots").join("joint_coordinates.png").exists());
}
