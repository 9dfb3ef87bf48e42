//! Figures and animation: every file exists and decodes, text renders from
//! the embedded font, the GIF has the expected frames and follows the
//! trajectory, and drawing is deterministic.

use cosim_server::engine::Model;
use cosim_server::plot::animation::{frames, marker, Camera};
use cosim_server::plot::{color, data::RunData};
use cosim_shared::Scene;
use image::AnimationDecoder;
mod common;

use common::TempDir;
use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_cosim-server");

const FIGURES: [&str; 9] = [
    "positions",
    "velocities",
    "quaternions",
    "energy",
    "normal_impulses",
    "friction_impulses",
    "joint_impulses",
    "solver",
    "lcp_size",
];

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
    let mut v: Vec<PathBuf> = FIGURES
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

    for f in FIGURES {
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
    // pixel at each sphere's projected centre has that sphere's colour.
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
        let radii: Vec<f64> = model
            .bodies
            .iter()
            .map(|body| match body.shape {
                cosim_server::engine::model::Shape::Sphere { radius } => radius,
            })
            .collect();
        if gap < (radii[0] + radii[1]) * cam.scale + 2.0 {
            continue;
        }
        for (b, &radius) in radii.iter().enumerate() {
            let (cx, cy) = cam.project(&centre(b, i));
            let (mx, my) = cam.project(&marker(radius, &run.bodies[b].rows[i]));
            if ((mx - cx).powi(2) + (my - cy).powi(2)).sqrt() < 0.3 * radius * cam.scale {
                continue;
            }
            let px = decoded[k]
                .buffer()
                .get_pixel(cx.round() as u32, cy.round() as u32)
                .0;
            let want = color(b);
            let dist = [
                px[0] as i32 - want.0 as i32,
                px[1] as i32 - want.1 as i32,
                px[2] as i32 - want.2 as i32,
            ];
            assert!(
                dist.iter().all(|d| d.abs() <= 24),
                "frame {k}, body {b}: pixel {px:?}, colour {want:?}"
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
    for (fa, fb) in files(&a).iter().zip(files(&b)) {
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
