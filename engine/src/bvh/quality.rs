//! Tree quality: the SAH cost of a binary tree. The rebuild heuristic's
//! area ratios are measured on the wide tree ([`super::wide`]).

use super::Node;

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
