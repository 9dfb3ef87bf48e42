//! `[[body]]` and `[[plane]]`: what collides, and the names of its contacts.

use serde::{Deserialize, Serialize};

/// `[[body]]`: a solid sphere (`radius`), capsule (`radius` and
/// `half_length`, its segment along the body's z axis, as MuJoCo's and
/// ODE's) or box (`half_extents`, along the body's axes).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BodyDesc {
    pub name: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_length: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_extents: Option<[f64; 3]>,
    pub mass: f64,
    /// `[ixx, iyy, izz, ixy, ixz, iyz]` about the centre of mass in the
    /// body's frame (kg m^2), as URDF's `<inertia>`; absent: the shape's
    /// at uniform density.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inertia: Option<[f64; 6]>,
    pub position: [f64; 3],
    /// Unit quaternion, scalar first.
    #[serde(default = "identity_quaternion")]
    pub orientation: [f64; 4],
    #[serde(default)]
    pub velocity: [f64; 3],
    #[serde(default)]
    pub angular_velocity: [f64; 3],
    #[serde(default)]
    pub friction: f64,
    #[serde(default)]
    pub restitution: f64,
    /// Constant world-frame force (N) on the centre of mass, besides gravity.
    #[serde(default)]
    pub force: [f64; 3],
    /// Bodies of one `group` never touch each other (a robot's links, as
    /// PyBullet leaves a robot without self-collision unless asked; Drake's
    /// collision filter groups); they touch everything else.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub group: Option<String>,
    /// `[[body.shape]]`: the body's shapes, each at its own pose in the
    /// body's frame, instead of one shape at the centre of mass given by
    /// the fields above; none at all for a body that touches nothing (a
    /// frame, a sensor: it needs `inertia`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shape: Vec<ShapeEntry>,
    /// `[[body.visual]]`: how the body looks where that is not its shapes
    /// (a robot's visual meshes); drawn, never collided.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub visual: Vec<super::VisualEntry>,
    /// `[[body.frame]]`: named frames fixed in the body (a robot's links
    /// merged into it by fixed joints: a hand, a camera mount, a tool
    /// tip), so that controllers and the recordings find them by name.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub frame: Vec<FrameEntry>,
}

/// `[[body.frame]]`: a named frame at `position` and `orientation` in its
/// body's frame (whose origin is the centre of mass). Its name is one of
/// the scene's: no body, joint or other frame has it.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FrameEntry {
    pub name: String,
    #[serde(default)]
    pub position: [f64; 3],
    /// Unit quaternion, scalar first.
    #[serde(default = "identity_quaternion")]
    pub orientation: [f64; 4],
}

/// `[[body.shape]]`: one of a body's shapes, a sphere (`radius`), capsule
/// (`radius`, `half_length`) or box (`half_extents`) as a body's single
/// shape is, at `position` and `orientation` in the body's frame (whose
/// origin is the centre of mass).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ShapeEntry {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_length: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_extents: Option<[f64; 3]>,
    /// Instead of the above: the convex hull of these points.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hull: Option<Vec<[f64; 3]>>,
    /// `"cylinder"` with `radius` and `half_length`: a cylinder about the
    /// shape's z axis (flat ends at +-half_length) instead of a capsule.
    #[serde(rename = "type", default, skip_serializing_if = "Option::is_none")]
    pub kind: Option<ShapeKind>,
    #[serde(default)]
    pub position: [f64; 3],
    /// Unit quaternion, scalar first.
    #[serde(default = "identity_quaternion")]
    pub orientation: [f64; 4],
}

/// `[[body.shape]] type`: what the fields make is named (only a cylinder
/// needs it: radius and half_length alone make a capsule).
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum ShapeKind {
    Cylinder,
}

/// A shape at its pose in its body's frame (`BodyDesc::shapes`).
#[derive(Debug, Clone, PartialEq)]
pub struct PlacedShape {
    pub shape: ShapeDesc,
    pub position: [f64; 3],
    pub orientation: [f64; 4],
}

impl PlacedShape {
    /// Whether it sits on the centre of mass, turned as the body.
    pub fn centred(&self) -> bool {
        self.position == [0.0; 3] && self.orientation == identity_quaternion()
    }
}

/// The most contacts one pair of shapes has: a box's eight vertices
/// against a plane (of which the engine lists the four lowest) bound every
/// pair's feature numbers.
pub const MAX_FEATURES: usize = 8;

/// The name a shape contact goes by in impulses.csv and the recordings:
/// `a/b` for a pair's first (a pair of spheres' only) contact, `a/b#k`
/// for its feature `k` (a box's vertex, a capsule's end...).
pub fn contact_label(a: &str, b: &str, feature: usize) -> String {
    if feature == 0 {
        format!("{a}/{b}")
    } else {
        format!("{a}/{b}#{feature}")
    }
}

/// A body's shape as the scene gives it (`BodyDesc::shape`).
#[derive(Debug, Clone, PartialEq)]
pub enum ShapeDesc {
    Sphere {
        radius: f64,
    },
    /// Half the segment's length along the body's z axis, and the radius.
    Capsule {
        radius: f64,
        half_length: f64,
    },
    Box {
        half_extents: [f64; 3],
    },
    /// A solid cylinder about the body's z axis, its flat ends
    /// `half_length` either side of its centre.
    Cylinder {
        radius: f64,
        half_length: f64,
    },
    /// The convex hull of these points (a collision mesh's, as MuJoCo and
    /// PyBullet take it), in the shape's frame.
    Hull {
        points: Vec<[f64; 3]>,
    },
}

/// The shape the fields `radius`, `half_length` and `half_extents` give, or
/// which are missing or clash (the field and the message).
fn shape_of(
    radius: Option<f64>,
    half_length: Option<f64>,
    half_extents: Option<[f64; 3]>,
) -> Result<ShapeDesc, (&'static str, String)> {
    match (radius, half_length, half_extents) {
        (Some(radius), None, None) => Ok(ShapeDesc::Sphere { radius }),
        (Some(radius), Some(half_length), None) => Ok(ShapeDesc::Capsule {
            radius,
            half_length,
        }),
        (None, None, Some(half_extents)) => Ok(ShapeDesc::Box { half_extents }),
        (None, Some(_), None) => Err((
            "radius",
            "is missing: a capsule needs radius beside half_length".into(),
        )),
        (None, None, None) => Err((
            "radius",
            "is missing: give radius (a sphere), radius and half_length (a capsule) \
             or half_extents (a box)"
                .into(),
        )),
        (_, _, Some(_)) => Err((
            "half_extents",
            "with radius or half_length: a shape is a box (half_extents alone), a \
             sphere (radius) or a capsule (radius and half_length)"
                .into(),
        )),
    }
}

impl ShapeEntry {
    pub fn shape_or_error(&self) -> Result<ShapeDesc, (&'static str, String)> {
        match (&self.hull, self.kind) {
            (None, Some(ShapeKind::Cylinder)) => match (self.radius, self.half_length) {
                (Some(radius), Some(half_length)) if self.half_extents.is_none() => {
                    Ok(ShapeDesc::Cylinder {
                        radius,
                        half_length,
                    })
                }
                _ => Err((
                    "type",
                    "= \"cylinder\": a cylinder is radius and half_length alone".into(),
                )),
            },
            (Some(_), Some(_)) => Err(("type", "with hull: a hull is its points alone".into())),
            (None, None) => shape_of(self.radius, self.half_length, self.half_extents),
            (Some(points), None)
                if self.radius.is_none()
                    && self.half_length.is_none()
                    && self.half_extents.is_none() =>
            {
                Ok(ShapeDesc::Hull {
                    points: points.clone(),
                })
            }
            (Some(_), None) => Err((
                "hull",
                "with radius, half_length or half_extents: a shape is one of them".into(),
            )),
        }
    }
}

impl BodyDesc {
    /// Whether the body's single shape is given by its own fields.
    pub(crate) fn has_own_shape(&self) -> bool {
        self.radius.is_some() || self.half_length.is_some() || self.half_extents.is_some()
    }

    /// The body's single shape, or which fields are missing or clash (the
    /// message of the error `validate` names the body's field with). A
    /// body given by `[[body.shape]]` has none of its own
    /// ([`BodyDesc::shapes`]).
    pub fn shape_or_error(&self) -> Result<ShapeDesc, (&'static str, String)> {
        shape_of(self.radius, self.half_length, self.half_extents)
    }

    /// Every shape of the body at its pose: its own (at the centre of
    /// mass) or its `[[body.shape]]` list; shapes `validate` refuses are
    /// left out.
    pub fn shapes(&self) -> Vec<PlacedShape> {
        if self.has_own_shape() || self.shape.is_empty() && self.inertia.is_none() {
            return vec![PlacedShape {
                shape: self.shape(),
                position: [0.0; 3],
                orientation: identity_quaternion(),
            }];
        }
        self.shape
            .iter()
            .filter_map(|e| {
                e.shape_or_error().ok().map(|shape| PlacedShape {
                    shape,
                    position: e.position,
                    orientation: e.orientation,
                })
            })
            .collect()
    }

    /// The body's single shape; a sphere of radius 0 where the description has
    /// none (`validate` refuses it first).
    pub fn shape(&self) -> ShapeDesc {
        self.shape_or_error()
            .unwrap_or(ShapeDesc::Sphere { radius: 0.0 })
    }
}

pub(super) fn identity_quaternion() -> [f64; 4] {
    [1.0, 0.0, 0.0, 0.0]
}

/// `[[plane]]`: a fixed infinite plane; bodies stay on the side its normal
/// points to.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PlaneDesc {
    pub name: String,
    pub normal: [f64; 3],
    pub point: [f64; 3],
    #[serde(default)]
    pub friction: f64,
    #[serde(default)]
    pub restitution: f64,
}
