//! Tree quality: the SAH cost, and the per-node area ratios behind the
//! rebuild heuristic of the dissertation (section 4.1.5).
//!
//! The ratio of an inner node is its area over the sum of its children's
//! areas. A node whose children drift apart grows while they do not, so its
//! ratio rises. The dissertation uses one primitive per leaf; our leaves hold
//! several, so a leaf's ratio is its area over the sum of its primitives'
//! box areas, which is what the inner nodes above it would measure. Leaves
//! with one primitive always measure 1 and are left out of the mean.

use super::Node;

/// Ratio of a box area to the sum of the areas it bounds; 1 when both are 0.
#[inline]
fn ratio(area: f32, parts: f32) -> f32 {
    if parts > 0.0 {
        area / parts
    } else if area > 0.0 {
        f32::MAX
    } else {
        1.0
    }
}

/// The area ratio of every node; `leaf_area_sum(first, count)` is the sum of
/// the primitives' half areas in a leaf.
pub(crate) fn area_ratios(nodes: &[Node], leaf_area_sum: impl Fn(u32, u32) -> f32) -> Vec<f32> {
    nodes
        .iter()
        .map(|n| node_ratio(nodes, n, &leaf_area_sum))
        .collect()
}

#[inline]
fn node_ratio(nodes: &[Node], n: &Node, leaf_area_sum: &impl Fn(u32, u32) -> f32) -> f32 {
    let area = n.aabb().half_area();
    if n.is_leaf() {
        if n.count() < 2 {
            1.0
        } else {
            ratio(area, leaf_area_sum(n.first(), n.count()))
        }
    } else {
        let l = n.first() as usize;
        ratio(
            area,
            nodes[l].aabb().half_area() + nodes[l + 1].aabb().half_area(),
        )
    }
}

/// The rebuild heuristic's measure: the mean, over inner nodes and leaves
/// with several primitives, of how much the area ratio grew since the build.
/// Zero under rigid translation; large when neighbours fly apart.
pub(crate) fn degradation(
    nodes: &[Node],
    build_ratios: &[f32],
    leaf_area_sum: impl Fn(u32, u32) -> f32,
) -> f32 {
    let (mut sum, mut count) = (0.0f64, 0usize);
    for (n, &built) in nodes.iter().zip(build_ratios) {
        if n.is_leaf() && n.count() < 2 {
            continue;
        }
        let now = node_ratio(nodes, n, &leaf_area_sum);
        sum += (now.min(1e6) - built.min(1e6)) as f64;
        count += 1;
    }
    if count == 0 {
        0.0
    } else {
        (sum / count as f64) as f32
    }
}

/// SAH cost of a tree with unit cost per primitive test and
/// `traversal_cost` per inner node, relative to a ray that hits the root:
/// `(Ct * sum(A(inner)) + sum(A(leaf) * n(leaf))) / A(root)`.
pub fn sah_cost(nodes: &[Node], traversal_cost: f32) -> f32 {
    let Some(root) = nodes.first() else {
        return 0.0;
    };
    let root_area = root.aabb().half_area();
    if root_area.is_nan() || root_area <= 0.0 {
        return nodes.iter().map(|n| n.count() as f32).sum();
    }
    let total: f64 = nodes
        .iter()
        .map(|n| {
            let a = n.aabb().half_area() as f64;
            if n.is_leaf() {
                a * n.count() as f64
            } else {
                a * traversal_cost as f64
            }
        })
        .sum();
    (total / root_area as f64) as f32
}
