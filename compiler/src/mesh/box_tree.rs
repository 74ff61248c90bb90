//! A static tree of boxes for "the first item from position `k` on whose box meets this box".
//!
//! Items are put in a spatial order once (median splits along the longest axis of their
//! centres, ties by input index, so the order depends only on the input); every node covers a
//! contiguous range of that order and holds the box around its items. A query walks the tree
//! front to back and skips nodes whose range ends before `k` or whose box misses the query, so it
//! touches the items near the query box, not all of them.

use sightline_formats::Aabb;

/// At most this many items in a leaf.
const LEAF_ITEMS: usize = 4;

#[derive(Debug, Clone)]
struct Node {
    bounds: Aabb,
    /// Positions `start..end` of [`BoxTree::order`].
    start: usize,
    end: usize,
    /// Second child (the first is the next node); `None` for a leaf.
    second: Option<usize>,
}

/// Boxes in a spatial order, with a tree over them.
#[derive(Debug, Clone, Default)]
pub(crate) struct BoxTree {
    /// Input index of the item at each position.
    order: Vec<usize>,
    /// Box of the item at each position.
    boxes: Vec<Aabb>,
    /// Pre-order: a node's first child follows it.
    nodes: Vec<Node>,
}

impl BoxTree {
    /// The tree over `boxes` (indexed as given).
    pub fn build(boxes: &[Aabb]) -> Self {
        let mut order: Vec<usize> = (0..boxes.len()).collect();
        let mut nodes = Vec::with_capacity(2 * boxes.len().div_ceil(LEAF_ITEMS));
        if !boxes.is_empty() {
            split(boxes, &mut order, 0, &mut nodes);
        }
        let ordered = order.iter().map(|&i| boxes[i]).collect();
        Self { order, boxes: ordered, nodes }
    }

    /// Input index of the item at `position`.
    pub fn item(&self, position: usize) -> usize {
        self.order[position]
    }

    /// The first position `p >= from` whose box meets `query` and for which `accept(p)` holds,
    /// trying positions in increasing order (so `accept` sees each candidate at most once).
    pub fn first_from(
        &self,
        from: usize,
        query: &Aabb,
        mut accept: impl FnMut(usize) -> bool,
    ) -> Option<usize> {
        let mut stack = Vec::with_capacity(32);
        if !self.nodes.is_empty() {
            stack.push(0usize);
        }
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i];
            if node.end <= from || !node.bounds.intersects(query) {
                continue;
            }
            match node.second {
                Some(second) => {
                    // Front to back: the first child (earlier positions) is popped first.
                    stack.push(second);
                    stack.push(i + 1);
                }
                None => {
                    for p in node.start.max(from)..node.end {
                        if self.boxes[p].intersects(query) && accept(p) {
                            return Some(p);
                        }
                    }
                }
            }
        }
        None
    }
}

/// Append the node over `order` (positions from `start` on) and its subtree.
fn split(boxes: &[Aabb], order: &mut [usize], start: usize, nodes: &mut Vec<Node>) {
    let bounds = order.iter().fold(Aabb::EMPTY, |b, &i| b.union(&boxes[i]));
    let index = nodes.len();
    let end = start + order.len();
    nodes.push(Node { bounds, start, end, second: None });
    if order.len() <= LEAF_ITEMS {
        return;
    }
    let centres = Aabb::from_points(order.iter().map(|&i| boxes[i].center()));
    let size = centres.size();
    let axis = if size.x >= size.y && size.x >= size.z {
        0
    } else if size.y >= size.z {
        1
    } else {
        2
    };
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |&a, &b| {
        boxes[a].center()[axis].total_cmp(&boxes[b].center()[axis]).then(a.cmp(&b))
    });
    let (first, second) = order.split_at_mut(mid);
    split(boxes, first, start, nodes);
    let second_index = nodes.len();
    split(boxes, second, start + mid, nodes);
    nodes[index].second = Some(second_index);
}

#[cfg(test)]
mod tests {
    use glam::DVec3;
    use sightline_job::rng::SplitMix64;

    use super::*;

    #[test]
    fn finds_the_first_meeting_box_from_any_position_as_a_scan_does() {
        let mut rng = SplitMix64::new(5);
        let mut unit = || (rng.next_u64() % 1000) as f64;
        let boxes: Vec<Aabb> = (0..300)
            .map(|_| {
                let lo = DVec3::new(unit(), unit(), 0.0);
                Aabb::new(lo, lo + DVec3::new(unit() / 20.0, unit() / 20.0, 1.0))
            })
            .collect();
        let tree = BoxTree::build(&boxes);
        let mut seen: Vec<usize> = (0..boxes.len()).map(|p| tree.item(p)).collect();
        seen.sort_unstable();
        assert!(seen.iter().copied().eq(0..boxes.len()), "every item has one position");
        for q in 0..200 {
            let lo = DVec3::new(unit(), unit(), 0.0);
            let query = Aabb::new(lo, lo + DVec3::splat(unit() / 5.0));
            let from = q % boxes.len();
            // Accept every other meeting item: the answer is the first accepted one in order.
            let keep = |p: usize| tree.item(p).is_multiple_of(2);
            let scan = (from..boxes.len()).find(|&p| boxes[tree.item(p)].intersects(&query) && keep(p));
            let mut asked = Vec::new();
            let found = tree.first_from(from, &query, |p| {
                asked.push(p);
                keep(p)
            });
            assert_eq!(found, scan);
            assert!(asked.windows(2).all(|w| w[0] < w[1]), "positions are tried in order");
        }
        assert_eq!(BoxTree::build(&[]).first_from(0, &Aabb::new(DVec3::ZERO, DVec3::ONE), |_| true), None);
    }
}
