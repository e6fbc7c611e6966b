//! The table of plane groups, kept up to date object by object.
//!
//! Planes are matched by quantising the normal (sign made canonical, since a
//! two-sided partition mirrors the same way from either side) and the
//! offset; each group's plane is that of its largest triangle, the most
//! accurately known, ties going to the lowest flat index, so that a table
//! updated object by object holds the same planes as one built at once.
//! Coplanar triangles that straddle a quantisation step land in two
//! groups, which costs one extra frustum, never a path.
//!
//! A group may hold triangles of several objects (a wall made of panels),
//! so each group records every object's share: moving one object removes
//! its shares and adds new ones, touching nothing else. A group left with
//! no share is retired and its id reused.

use std::collections::HashMap;

use super::{Plane, SurfaceGroup, NO_GROUP};
use crate::scene::MaterialId;

/// Quantised normal, offset and material: triangles with equal keys share
/// a group.
type Key = (i64, i64, i64, i64, MaterialId);

/// One object's triangles in a group, and its largest.
#[derive(Clone, Debug)]
struct Share {
    object: u32,
    triangles: u32,
    area: f64,
    /// Flat index of the largest triangle (the first of equals).
    slot: u32,
    plane: Plane,
}

#[derive(Clone, Debug)]
struct Entry {
    group: SurfaceGroup,
    key: Key,
    /// Empty: retired, its id free.
    shares: Vec<Share>,
}

#[derive(Clone, Debug, Default)]
pub(super) struct GroupTable {
    entries: Vec<Entry>,
    index: HashMap<Key, u32>,
    free: Vec<u32>,
    offset_step: f64,
}

impl GroupTable {
    /// A table for a scene whose box has diagonal `scale`.
    pub(super) fn new(scale: f64) -> Self {
        Self {
            offset_step: offset_step(scale),
            ..Self::default()
        }
    }

    /// Whether a scene of diagonal `scale` quantises offsets with this
    /// table's step; when the step changes, every key does, and the table
    /// must be rebuilt.
    pub(super) fn fits_scale(&self, scale: f64) -> bool {
        self.offset_step == offset_step(scale)
    }

    pub(super) fn get(&self, g: u32) -> &SurfaceGroup {
        &self.entries[g as usize].group
    }

    /// Live groups with their ids.
    pub(super) fn iter(&self) -> impl Iterator<Item = (u32, &SurfaceGroup)> {
        self.entries
            .iter()
            .enumerate()
            .filter(|(_, e)| !e.shares.is_empty())
            .map(|(g, e)| (g as u32, &e.group))
    }

    pub(super) fn len(&self) -> usize {
        self.entries.len() - self.free.len()
    }

    /// Groups `object`'s triangles, whose planes (with areas) and materials
    /// are given per flat index from `base`, and writes their groups.
    pub(super) fn add_object(
        &mut self,
        object: u32,
        base: usize,
        planes: &[Option<(Plane, f64)>],
        materials: &[MaterialId],
        slot_group: &mut [u32],
    ) {
        const NORMAL_STEP: f64 = 1e-5;
        let q = |x: f64, step: f64| (x / step).round() as i64;
        let mut shares: HashMap<u32, Share> = HashMap::new();
        for (i, (plane, &material)) in planes.iter().zip(materials).enumerate() {
            let Some((plane, area)) = *plane else {
                slot_group[i] = NO_GROUP;
                continue;
            };
            let key = (
                q(plane.normal.x, NORMAL_STEP),
                q(plane.normal.y, NORMAL_STEP),
                q(plane.normal.z, NORMAL_STEP),
                q(plane.offset, self.offset_step),
                material,
            );
            let g = match self.index.get(&key) {
                Some(&g) => g,
                None => self.open(key, plane, material),
            };
            slot_group[i] = g;
            let slot = (base + i) as u32;
            let share = shares.entry(g).or_insert(Share {
                object,
                triangles: 0,
                area,
                slot,
                plane,
            });
            share.triangles += 1;
            if area > share.area {
                (share.area, share.slot, share.plane) = (area, slot, plane);
            }
        }
        for (g, share) in shares {
            let entry = &mut self.entries[g as usize];
            entry.shares.push(share);
            entry.settle();
        }
    }

    /// Takes `object`'s triangles, whose groups are `slot_group`, out of
    /// their groups.
    pub(super) fn remove_object(&mut self, object: u32, slot_group: &[u32]) {
        let mut touched: Vec<u32> = slot_group
            .iter()
            .copied()
            .filter(|&g| g != NO_GROUP)
            .collect();
        touched.sort_unstable();
        touched.dedup();
        for g in touched {
            let entry = &mut self.entries[g as usize];
            entry.shares.retain(|s| s.object != object);
            if entry.shares.is_empty() {
                self.index.remove(&entry.key);
                self.free.push(g);
            } else {
                entry.settle();
            }
        }
    }

    /// A new group for `key`, in a retired id if there is one.
    fn open(&mut self, key: Key, plane: Plane, material: MaterialId) -> u32 {
        let entry = Entry {
            group: SurfaceGroup { plane, material },
            key,
            shares: Vec::new(),
        };
        let g = match self.free.pop() {
            Some(g) => {
                self.entries[g as usize] = entry;
                g
            }
            None => {
                self.entries.push(entry);
                self.entries.len() as u32 - 1
            }
        };
        self.index.insert(key, g);
        g
    }
}

/// About a millionth of the scene's size, rounded up to a power of two: an
/// object moving at the scene's edge changes the scene box by rounding,
/// which must not move every key.
fn offset_step(scale: f64) -> f64 {
    (scale * 1e-6).log2().ceil().exp2()
}

impl Entry {
    /// The group's plane from its largest triangle over all shares.
    fn settle(&mut self) {
        let best = self
            .shares
            .iter()
            .max_by(|a, b| a.area.total_cmp(&b.area).then(b.slot.cmp(&a.slot)))
            .expect("a settled group has a share");
        self.group.plane = best.plane;
    }
}
