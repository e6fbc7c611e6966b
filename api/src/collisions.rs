//! `POST /v1/scenes/{id}/collisions`: which triangles of which objects
//! touch, come close, or meet during a motion, optionally after moving
//! objects in the same atomic step.

use frusta_engine::collision::{all_pairs, CollisionQuery, CollisionTest, Found};
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::objects::ObjectMove;
use crate::schemas::ObjectPair;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum CollisionKind {
    /// Triangles that intersect (touching counts), decided exactly, in
    /// the poses after `moves`.
    #[default]
    Discrete,
    /// Triangles at most `distance` apart, with their distance, in the
    /// poses after `moves`.
    Proximity,
    /// Triangles that meet while every vertex moves in a straight line
    /// from its current position to its position after `moves`, with the
    /// earliest time each pair does (0 now, 1 at the end of the motion).
    Continuous,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CollisionRequest {
    #[serde(default)]
    pub kind: CollisionKind,
    /// Object pairs to test, by name or index. Omitted, with `self` also
    /// omitted: every pair of distinct objects.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<Vec<ObjectPair>>, max_items = 4096)]
    pub pairs: Option<Vec<[String; 2]>>,
    /// Objects tested against themselves (self-collision: triangles that
    /// share no corner). Not for proximity, where neighbours always touch.
    #[serde(default, rename = "self", skip_serializing_if = "Vec::is_empty")]
    #[schema(max_items = 4096)]
    pub self_objects: Vec<String>,
    /// Proximity only (required there): the largest distance reported,
    /// metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 0.0)]
    pub distance: Option<f64>,
    /// Continuous only: distance at which moving primitives count as
    /// touching, metres; default a millionth of the scene's size.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(exclusive_minimum = 0.0)]
    pub tolerance: Option<f64>,
    /// Moves applied (and the hierarchies refitted) in the same step as
    /// the query, stored like `PATCH …/objects/{object}`. Discrete and
    /// proximity queries see the objects after them; a continuous query
    /// sees the motion from before to after.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    #[schema(max_items = 4096)]
    pub moves: Vec<ObjectMove>,
    /// Most contacts listed (default 1,000, at most 100,000); `total`
    /// counts them all.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(minimum = 0, maximum = 100000)]
    pub max_contacts: Option<usize>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct CollisionResponse {
    /// The scene's revision the answer is for (after `moves`).
    pub revision: u64,
    pub kind: CollisionKind,
    /// Sorted by object pair and triangles; continuous contacts by time
    /// first.
    pub contacts: Vec<TriangleContact>,
    /// Contacts found, listed or not.
    pub total: usize,
    /// Whether `contacts` stops short of `total` (`max_contacts`).
    pub truncated: bool,
    /// Continuous only: the earliest time of impact of all contacts, or
    /// null when nothing meets.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub earliest_time: Option<f64>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct TriangleContact {
    pub a: TriangleRef,
    pub b: TriangleRef,
    /// Discrete only: where the triangles meet, in the world, metres: the
    /// two ends of the segment they share (one point where they touch at a
    /// point), or the corners of the polygon they share where coplanar.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(value_type = Option<Vec<[f64; 3]>>)]
    pub points: Option<Vec<[f64; 3]>>,
    /// Proximity only: the triangles' distance, metres (0 where they
    /// intersect).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distance: Option<f64>,
    /// Continuous only: earliest time in [0, 1] at which the pair meets.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time: Option<f64>,
}

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct TriangleRef {
    pub object: String,
    /// Triangle index in the object's mesh.
    pub triangle: u32,
}

impl CollisionResponse {
    /// The answer for `found` (in the engine's order) on a scene whose
    /// objects are `names`, listing at most `max` contacts.
    pub fn new(
        revision: u64,
        kind: CollisionKind,
        mut found: Vec<Found>,
        names: &[String],
        max: usize,
    ) -> Self {
        let total = found.len();
        let earliest_time = found.iter().filter_map(|f| f.time).reduce(f64::min);
        found.truncate(max);
        let name = |(object, triangle): (u32, u32)| TriangleRef {
            object: names[object as usize].clone(),
            triangle,
        };
        Self {
            revision,
            kind,
            contacts: found
                .into_iter()
                .map(|f| TriangleContact {
                    a: name(f.contact.a),
                    b: name(f.contact.b),
                    points: (kind == CollisionKind::Discrete)
                        .then(|| f.points.iter().map(|p| p.to_array()).collect()),
                    distance: f.distance,
                    time: f.time,
                })
                .collect(),
            total,
            truncated: total > max,
            earliest_time,
        }
    }
}

/// The object called `name` among `names`, or the one at that index when
/// `name` is all digits and no object has it as its name.
pub fn object_by_name(names: &[String], name: &str) -> Result<u32, frusta_engine::Error> {
    names
        .iter()
        .position(|n| n == name)
        .or_else(|| name.parse::<usize>().ok().filter(|&i| i < names.len()))
        .map(|i| i as u32)
        .ok_or_else(|| {
            frusta_engine::Error::UnknownObject(format!(
                "`{name}` (the scene has {} objects)",
                names.len()
            ))
        })
}

impl CollisionRequest {
    /// The engine's query for this request (its moves aside) on a scene
    /// whose objects are `names`, checked: the server and the command line
    /// read a request alike.
    pub fn query(&self, names: &[String]) -> Result<CollisionQuery, frusta_engine::Error> {
        let invalid = |field: &str, reason: &str| frusta_engine::Error::InvalidOption {
            field: field.into(),
            reason: reason.into(),
        };
        let test = match self.kind {
            CollisionKind::Discrete => CollisionTest::Discrete,
            CollisionKind::Proximity => CollisionTest::Proximity {
                distance: self
                    .distance
                    .ok_or_else(|| invalid("distance", "a proximity query needs a distance"))?,
            },
            CollisionKind::Continuous => CollisionTest::Continuous {
                tolerance: self.tolerance,
            },
        };
        if self.distance.is_some() && self.kind != CollisionKind::Proximity {
            return Err(invalid(
                "distance",
                "only a proximity query takes a distance",
            ));
        }
        if self.tolerance.is_some() && self.kind != CollisionKind::Continuous {
            return Err(invalid(
                "tolerance",
                "only a continuous query takes a tolerance",
            ));
        }
        let pairs = match &self.pairs {
            Some(pairs) => pairs
                .iter()
                .map(|[a, b]| Ok((object_by_name(names, a)?, object_by_name(names, b)?)))
                .collect::<Result<Vec<_>, frusta_engine::Error>>()?,
            None if self.self_objects.is_empty() => all_pairs(names.len()),
            None => Vec::new(),
        };
        let selves = self
            .self_objects
            .iter()
            .map(|name| object_by_name(names, name))
            .collect::<Result<Vec<_>, _>>()?;
        let query = CollisionQuery {
            test,
            pairs,
            selves,
        };
        query.check(names.len())?;
        Ok(query)
    }
}
