//! Tarjan's strongly connected components.

use std::collections::BTreeSet;

/// The strongly connected components of the graph of `n` nodes and the arcs `arcs`, each
/// component's nodes sorted, the components in the order Tarjan's algorithm closes them.
pub(crate) fn strongly_connected(n: usize, arcs: &BTreeSet<(usize, usize)>) -> Vec<Vec<usize>> {
    let mut next = vec![Vec::new(); n];
    for &(a, b) in arcs {
        if let Some(out) = next.get_mut(a)
            && b < n
        {
            out.push(b);
        }
    }
    let mut t = Tarjan { next, index: vec![None; n], low: vec![0; n], on_stack: vec![false; n], ..Tarjan::default() };
    for v in 0..n {
        if t.index.get(v).is_some_and(Option::is_none) {
            t.visit(v);
        }
    }
    t.components
}

#[derive(Default)]
struct Tarjan {
    next: Vec<Vec<usize>>,
    index: Vec<Option<usize>>,
    low: Vec<usize>,
    on_stack: Vec<bool>,
    stack: Vec<usize>,
    counter: usize,
    components: Vec<Vec<usize>>,
}

impl Tarjan {
    fn visit(&mut self, v: usize) {
        self.index[v] = Some(self.counter);
        self.low[v] = self.counter;
        self.counter += 1;
        self.stack.push(v);
        self.on_stack[v] = true;
        for w in self.next[v].clone() {
            match self.index[w] {
                None => {
                    self.visit(w);
                    self.low[v] = self.low[v].min(self.low[w]);
                }
                Some(iw) if self.on_stack[w] => self.low[v] = self.low[v].min(iw),
                Some(_) => {}
            }
        }
        if Some(self.low[v]) == self.index[v] {
            let mut component = Vec::new();
            while let Some(w) = self.stack.pop() {
                self.on_stack[w] = false;
                component.push(w);
                if w == v {
                    break;
                }
            }
            component.sort_unstable();
            self.components.push(component);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cycle_a_tail_and_a_self_loop() {
        // 0 → 1 → 2 → 0 is a circle; 2 → 3 a tail; 4 → 4 stays alone.
        let arcs = [(0, 1), (1, 2), (2, 0), (2, 3), (4, 4)].into_iter().collect();
        let mut c = strongly_connected(5, &arcs);
        c.sort();
        assert_eq!(c, [vec![0, 1, 2], vec![3], vec![4]]);
    }
}
