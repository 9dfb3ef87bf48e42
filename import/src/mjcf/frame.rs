//! Poses as MJCF writes them: `pos` and one of `quat`, `axisangle`,
//! `euler`, `xyaxes`, `zaxis` (or a geom's `fromto`), with the compiler's
//! `angle` unit and `eulerseq`, converted as MuJoCo's compiler does.

use nalgebra::{Isometry3, Matrix3, Quaternion, Rotation3, Translation3, UnitQuaternion, Vector3};

/// The compiler settings poses depend on.
#[derive(Debug, Clone)]
pub struct Angles {
    /// Radians per unit of the file's angles (pi/180 for `degree`, the
    /// default).
    pub unit: f64,
    /// Three of `xyzXYZ`: lower case about the moving frame's axes.
    pub eulerseq: [u8; 3],
}

impl Default for Angles {
    fn default() -> Self {
        Angles {
            unit: std::f64::consts::PI / 180.0,
            eulerseq: *b"xyz",
        }
    }
}

/// The rotation taking +z to the direction `v` by the shortest arc
/// (MuJoCo's `zaxis` and `fromto`); about x by pi when `v` points down.
pub fn z_to(v: &Vector3<f64>) -> Option<UnitQuaternion<f64>> {
    let n = v.norm();
    if !n.is_finite() || n <= 1e-14 {
        return None;
    }
    let v = v / n;
    let z = Vector3::z();
    let axis = z.cross(&v);
    let s = axis.norm();
    if s < 1e-14 {
        return Some(if v.z > 0.0 {
            UnitQuaternion::identity()
        } else {
            UnitQuaternion::from_quaternion(Quaternion::new(0.0, 1.0, 0.0, 0.0))
        });
    }
    let angle = s.atan2(z.dot(&v));
    Some(UnitQuaternion::from_axis_angle(
        &nalgebra::Unit::new_unchecked(axis / s),
        angle,
    ))
}

/// The orientation an element's attributes give (`get` reads a numeric
/// attribute), identity when none; `Err` names the attribute at fault.
pub fn orientation(
    get: &dyn Fn(&str) -> Option<Vec<f64>>,
    angles: &Angles,
) -> Result<UnitQuaternion<f64>, String> {
    let given: Vec<&str> = ["quat", "axisangle", "euler", "xyaxes", "zaxis"]
        .into_iter()
        .filter(|a| get(a).is_some())
        .collect();
    if given.len() > 1 {
        return Err(format!(
            "{given:?} all give the orientation: MuJoCo takes one of them"
        ));
    }
    let want = |a: &str, n: usize| -> Result<Vec<f64>, String> {
        let v = get(a).unwrap_or_default();
        if v.len() != n || v.iter().any(|x| !x.is_finite()) {
            Err(format!("{a}: {n} finite numbers expected, found {v:?}"))
        } else {
            Ok(v)
        }
    };
    match given.first().copied() {
        None => Ok(UnitQuaternion::identity()),
        Some("quat") => {
            let q = want("quat", 4)?;
            let q = Quaternion::new(q[0], q[1], q[2], q[3]);
            if q.norm() < 1e-14 {
                return Err("quat: is zero".into());
            }
            Ok(UnitQuaternion::from_quaternion(q))
        }
        Some("axisangle") => {
            let v = want("axisangle", 4)?;
            let axis = Vector3::new(v[0], v[1], v[2]);
            let n = axis.norm();
            if n < 1e-14 {
                return Err("axisangle: the axis is zero".into());
            }
            Ok(UnitQuaternion::from_axis_angle(
                &nalgebra::Unit::new_unchecked(axis / n),
                v[3] * angles.unit,
            ))
        }
        Some("euler") => {
            let v = want("euler", 3)?;
            let mut q = UnitQuaternion::identity();
            for (k, &c) in angles.eulerseq.iter().enumerate() {
                let axis = match c.to_ascii_lowercase() {
                    b'x' => Vector3::x_axis(),
                    b'y' => Vector3::y_axis(),
                    _ => Vector3::z_axis(),
                };
                let r = UnitQuaternion::from_axis_angle(&axis, v[k] * angles.unit);
                // Lower case: about the axes as already turned.
                q = if c.is_ascii_lowercase() { q * r } else { r * q };
            }
            Ok(q)
        }
        Some("xyaxes") => {
            let v = want("xyaxes", 6)?;
            let x = Vector3::new(v[0], v[1], v[2]);
            let y = Vector3::new(v[3], v[4], v[5]);
            let x = x.try_normalize(1e-14).ok_or("xyaxes: the x axis is zero")?;
            let y = (y - x * x.dot(&y))
                .try_normalize(1e-14)
                .ok_or("xyaxes: the y axis is zero or along x")?;
            let z = x.cross(&y);
            let m = Matrix3::from_columns(&[x, y, z]);
            Ok(UnitQuaternion::from_rotation_matrix(
                &Rotation3::from_matrix_unchecked(m),
            ))
        }
        Some(_) => {
            let v = want("zaxis", 3)?;
            z_to(&Vector3::new(v[0], v[1], v[2])).ok_or_else(|| "zaxis: is zero".into())
        }
    }
}

/// The pose of `pos` (default zero) and the orientation.
pub fn pose(
    get: &dyn Fn(&str) -> Option<Vec<f64>>,
    angles: &Angles,
) -> Result<Isometry3<f64>, String> {
    let p = match get("pos") {
        None => Vector3::zeros(),
        Some(v) if v.len() == 3 && v.iter().all(|x| x.is_finite()) => {
            Vector3::new(v[0], v[1], v[2])
        }
        Some(v) => return Err(format!("pos: 3 finite numbers expected, found {v:?}")),
    };
    Ok(Isometry3::from_parts(
        Translation3::from(p),
        orientation(get, angles)?,
    ))
}
