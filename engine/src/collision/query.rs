//! One collision query over the world: which object pairs and which
//! objects against themselves, and what kind of test, run in the world as
//! it is or over a step of motion. What the service and the command line
//! answer, in one place.

use std::time::Instant;

use glam::DVec3;

use super::continuous::{
    self_sweep_contacts_until, sweep_contacts_until, CcdOptions, EndPose, Sweep,
};
use super::discrete::{object_contacts_at, proximity_until, self_contacts_at};
use super::Contact;
use crate::bvh::SceneBvh;
use crate::deadline::{Cancel, Deadline};
use crate::{Error, Result};

/// The kind of test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CollisionTest {
    /// Triangles that intersect, decided exactly.
    Discrete,
    /// Triangles at most this far apart.
    Proximity { distance: f64 },
    /// Triangles that meet during a step of motion, with the distance at
    /// which they count as touching (default a millionth of the world's
    /// size).
    Continuous { tolerance: Option<f64> },
}

/// A collision query: a test, object pairs, and objects tested against
/// themselves.
#[derive(Clone, Debug, PartialEq)]
pub struct CollisionQuery {
    pub test: CollisionTest,
    /// `(a, b)` with `a != b`.
    pub pairs: Vec<(u32, u32)>,
    pub selves: Vec<u32>,
}

/// A contact found, with where the triangles meet (discrete), their
/// distance (proximity) or the earliest time they meet (continuous).
#[derive(Clone, Debug, PartialEq)]
pub struct Found {
    pub contact: Contact,
    /// Discrete: [`super::contact_points`] in the world.
    pub points: Vec<DVec3>,
    pub distance: Option<f64>,
    pub time: Option<f64>,
}

fn invalid(field: &str, reason: String) -> Error {
    Error::InvalidOption {
        field: field.into(),
        reason,
    }
}

/// Every pair of distinct objects of a world of `objects` objects.
pub fn all_pairs(objects: usize) -> Vec<(u32, u32)> {
    let n = objects as u32;
    (0..n)
        .flat_map(|a| (a + 1..n).map(move |b| (a, b)))
        .collect()
}

impl CollisionQuery {
    /// Checks the query against a world of `objects` objects: known
    /// objects, no object paired with itself, a distance of at least 0, a
    /// positive tolerance, and no self test for proximity (where
    /// neighbouring triangles always touch).
    pub fn check(&self, objects: usize) -> Result<()> {
        match self.test {
            CollisionTest::Proximity { distance } if !(distance.is_finite() && distance >= 0.0) => {
                return Err(invalid(
                    "distance",
                    format!("{distance} is not a distance of at least 0"),
                ))
            }
            CollisionTest::Proximity { .. } if !self.selves.is_empty() => {
                return Err(invalid(
                    "self",
                    "proximity has no self form: neighbouring triangles always touch".into(),
                ))
            }
            CollisionTest::Continuous { tolerance: Some(t) } if !(t.is_finite() && t > 0.0) => {
                return Err(invalid(
                    "tolerance",
                    format!("{t} is not a positive distance"),
                ))
            }
            _ => {}
        }
        let known = |o: u32| {
            if (o as usize) < objects {
                Ok(())
            } else {
                Err(Error::UnknownObject(format!(
                    "#{o} (the scene has {objects})"
                )))
            }
        };
        for &(a, b) in &self.pairs {
            known(a)?;
            known(b)?;
            if a == b {
                return Err(invalid(
                    "pairs",
                    format!("object #{a} paired with itself: test it against itself instead"),
                ));
            }
        }
        self.selves.iter().try_for_each(|&o| known(o))
    }

    /// Runs the query in the world as it is (a continuous query with
    /// nothing moving finds what touches now, at time 0), failing with
    /// [`Error::DeadlineExceeded`] once `deadline` has passed and with
    /// [`Error::Cancelled`] soon after `cancel` is cancelled.
    pub fn run(
        &self,
        world: &SceneBvh,
        deadline: Option<Instant>,
        cancel: Option<&Cancel>,
    ) -> Result<Vec<Found>> {
        match self.test {
            CollisionTest::Continuous { .. } => self.run_during(world, &[], deadline, cancel),
            _ => self.run_now(
                world,
                &Deadline::new(deadline, Instant::now()).or_cancel(cancel),
            ),
        }
    }

    fn run_now(&self, world: &SceneBvh, stop: &Deadline) -> Result<Vec<Found>> {
        self.check(world.object_count())?;
        let mut found = Vec::new();
        for &(a, b) in &self.pairs {
            // Each object pair reads the clock once at least, however
            // little its walk finds to do.
            stop.check()?;
            match self.test {
                CollisionTest::Proximity { distance } => found.extend(
                    proximity_until(world, a, b, distance, stop)?
                        .into_iter()
                        .map(|(contact, d)| Found {
                            contact,
                            points: Vec::new(),
                            distance: Some(d),
                            time: None,
                        }),
                ),
                _ => found.extend(
                    object_contacts_at(world, a, b, stop)?
                        .into_iter()
                        .map(discrete),
                ),
            }
        }
        for &o in &self.selves {
            stop.check()?;
            found.extend(self_contacts_at(world, o, stop)?.into_iter().map(discrete));
        }
        Ok(found)
    }

    /// Runs a continuous query over the step from the world as it is to
    /// `ends` (objects not named there stay), earliest contact first; a
    /// discrete or proximity query ignores `ends`. Fails as
    /// [`run`](Self::run) does past `deadline` or on `cancel`.
    pub fn run_during(
        &self,
        world: &SceneBvh,
        ends: &[(u32, EndPose)],
        deadline: Option<Instant>,
        cancel: Option<&Cancel>,
    ) -> Result<Vec<Found>> {
        let stop = Deadline::new(deadline, Instant::now()).or_cancel(cancel);
        let CollisionTest::Continuous { tolerance } = self.test else {
            return self.run_now(world, &stop);
        };
        self.check(world.object_count())?;
        let size = f64::from(world.bounds().extent().max_element());
        let options = CcdOptions {
            tolerance: tolerance.unwrap_or(1e-6 * size.max(f64::from(f32::MIN_POSITIVE))),
            ..CcdOptions::default()
        };
        let mut involved: Vec<u32> = self
            .pairs
            .iter()
            .flat_map(|&(a, b)| [a, b])
            .chain(self.selves.iter().copied())
            .collect();
        involved.sort_unstable();
        involved.dedup();
        let sweeps = involved
            .iter()
            .map(|&o| {
                let end = ends
                    .iter()
                    .find(|(e, _)| *e == o)
                    .map_or(EndPose::Stays, |(_, end)| *end);
                Sweep::new(world, o, end, &options)
            })
            .collect::<Result<Vec<_>>>()?;
        let sweep = |o: u32| &sweeps[involved.binary_search(&o).expect("swept")];
        let timed = |c: super::continuous::SweptContact| Found {
            contact: c.contact,
            points: Vec::new(),
            distance: None,
            time: Some(c.time),
        };
        let mut found: Vec<Found> = Vec::new();
        for &(a, b) in &self.pairs {
            stop.check()?;
            let (sa, sb) = (sweep(a), sweep(b));
            if sa.bounds().overlaps(&sb.bounds()) {
                found.extend(
                    sweep_contacts_until(sa, sb, &options, &stop)?
                        .into_iter()
                        .map(timed),
                );
            }
        }
        for &o in &self.selves {
            stop.check()?;
            found.extend(
                self_sweep_contacts_until(sweep(o), &options, &stop)?
                    .into_iter()
                    .map(timed),
            );
        }
        found.sort_by(|x, y| {
            let time = |f: &Found| f.time.unwrap_or(0.0);
            time(x).total_cmp(&time(y)).then(x.contact.cmp(&y.contact))
        });
        Ok(found)
    }
}

fn discrete((contact, points): (Contact, Vec<DVec3>)) -> Found {
    Found {
        contact,
        points,
        distance: None,
        time: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn query(test: CollisionTest, pairs: Vec<(u32, u32)>, selves: Vec<u32>) -> CollisionQuery {
        CollisionQuery {
            test,
            pairs,
            selves,
        }
    }

    #[test]
    fn bad_queries_are_refused_with_the_field_at_fault() {
        let field = |q: CollisionQuery| match q.check(3) {
            Err(Error::InvalidOption { field, .. }) => field,
            other => panic!("{other:?}"),
        };
        let near = |distance| CollisionTest::Proximity { distance };
        assert_eq!(field(query(near(-1.0), vec![], vec![])), "distance");
        assert_eq!(field(query(near(f64::NAN), vec![], vec![])), "distance");
        assert_eq!(field(query(near(1.0), vec![], vec![0])), "self");
        let sweep = |t| CollisionTest::Continuous { tolerance: Some(t) };
        assert_eq!(field(query(sweep(0.0), vec![], vec![])), "tolerance");
        assert_eq!(
            field(query(sweep(f64::INFINITY), vec![], vec![])),
            "tolerance"
        );
        assert_eq!(
            field(query(CollisionTest::Discrete, vec![(1, 1)], vec![])),
            "pairs"
        );
        let unknown = query(CollisionTest::Discrete, vec![(0, 3)], vec![]);
        assert!(matches!(unknown.check(3), Err(Error::UnknownObject(_))));
        assert!(query(CollisionTest::Discrete, all_pairs(3), vec![2])
            .check(3)
            .is_ok());
        assert_eq!(all_pairs(3), vec![(0, 1), (0, 2), (1, 2)]);
    }
}
