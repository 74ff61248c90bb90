//! Structural checks on node trees read from files, shared by the BSP and `.slvl` readers.

/// Checks that the node graph (children `c >= 0` are nodes, as Quake encodes them) has no cycle,
/// so that any walk down from any node ends in a leaf. Child indices must already be in range.
/// Returns the index of a node on a cycle when there is one.
pub(crate) fn find_cycle(children: &[[i32; 2]]) -> Option<usize> {
    // Kahn's algorithm: repeatedly remove nodes nobody points at; what remains lies on or under a
    // cycle.
    let n = children.len();
    let mut indegree = vec![0u32; n];
    for pair in children {
        for &c in pair {
            if let Some(d) = usize::try_from(c).ok().and_then(|c| indegree.get_mut(c)) {
                *d += 1;
            }
        }
    }
    let mut stack: Vec<usize> = (0..n).filter(|&i| indegree[i] == 0).collect();
    let mut removed = 0;
    while let Some(i) = stack.pop() {
        removed += 1;
        for &c in &children[i] {
            if let Some(c) = usize::try_from(c).ok().filter(|&c| c < n) {
                indegree[c] -= 1;
                if indegree[c] == 0 {
                    stack.push(c);
                }
            }
        }
    }
    if removed == n { None } else { indegree.iter().position(|&d| d > 0) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_cycles_only() {
        assert_eq!(find_cycle(&[[1, -1], [2, -2], [-1, -3]]), None);
        assert_eq!(find_cycle(&[[1, 1], [-1, -2]]), None);
        assert!(find_cycle(&[[1, -1], [0, -2]]).is_some());
        assert!(find_cycle(&[[0, -1]]).is_some());
        assert!(find_cycle(&[[-1, -1], [2, -1], [1, -1]]).is_some());
    }
}
