//! Contact caching (warm starting): this step's contact points take last step's lambdas
//! where the same body pair touches with the same features.
//!
//! Both steps' contacts are sorted by body pair, so matching is one merge pass: no hash
//! map, no search, and the result does not depend on anything but the pairs.

use super::{Contact, Manifold};

/// Copies lambdas from `old` into the points of `new` with the same feature id.
#[inline]
pub(crate) fn match_points(old: &Manifold, new: &mut Manifold) {
    for p in &mut new.points[..new.count] {
        if let Some(q) = old.points[..old.count].iter().find(|q| q.id == p.id) {
            p.normal_impulse = q.normal_impulse;
            p.tangent_impulse = q.tangent_impulse;
        }
    }
}

/// A cursor over last step's contacts, sorted by pair; ask for pairs in increasing order.
pub(crate) struct CacheCursor<'a> {
    old: &'a [Contact],
    at: usize,
}

impl<'a> CacheCursor<'a> {
    /// Starts at the beginning of `old` (sorted by (a, b)).
    pub(crate) fn new(old: &'a [Contact]) -> Self {
        Self { old, at: 0 }
    }

    /// Last step's manifold of the pair (a, b), if it touched. Pairs must be asked in
    /// increasing order.
    #[inline]
    pub(crate) fn find(&mut self, a: u32, b: u32) -> Option<&'a Manifold> {
        while self.at < self.old.len() && (self.old[self.at].a, self.old[self.at].b) < (a, b) {
            self.at += 1;
        }
        match self.old.get(self.at) {
            Some(c) if c.a == a && c.b == b => Some(&c.manifold),
            _ => None,
        }
    }

    /// Every manifold of last step's pair (a, b): one per pair of touching parts when a
    /// body is a compound. Pairs must be asked in increasing order.
    #[inline]
    pub(crate) fn find_all(&mut self, a: u32, b: u32) -> &'a [Contact] {
        while self.at < self.old.len() && (self.old[self.at].a, self.old[self.at].b) < (a, b) {
            self.at += 1;
        }
        let rest = &self.old[self.at..];
        let n = rest.iter().take_while(|c| c.a == a && c.b == b).count();
        &rest[..n]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collision::ContactPoint;

    #[test]
    fn points_match_by_feature_id() {
        let mut old = Manifold {
            count: 2,
            ..Default::default()
        };
        old.points[0] = ContactPoint {
            id: 7,
            normal_impulse: 1.5,
            tangent_impulse: -0.25,
            ..Default::default()
        };
        old.points[1] = ContactPoint {
            id: 9,
            normal_impulse: 2.5,
            tangent_impulse: 0.75,
            ..Default::default()
        };
        let mut new = Manifold {
            count: 2,
            ..Default::default()
        };
        new.points[0].id = 9;
        new.points[1].id = 8; // a feature that did not touch before
        match_points(&old, &mut new);
        // the friction lambda travels with the normal one; a new feature starts at zero
        assert_eq!(
            (new.points[0].normal_impulse, new.points[0].tangent_impulse),
            (2.5, 0.75)
        );
        assert_eq!(
            (new.points[1].normal_impulse, new.points[1].tangent_impulse),
            (0.0, 0.0)
        );
        // and the other way round
        let mut swapped = Manifold {
            count: 1,
            ..Default::default()
        };
        swapped.points[0].id = 7;
        match_points(&old, &mut swapped);
        assert_eq!(
            (
                swapped.points[0].normal_impulse,
                swapped.points[0].tangent_impulse
            ),
            (1.5, -0.25)
        );
    }

    #[test]
    fn cursor_finds_pairs_in_order() {
        let mk = |a, b, id| {
            let mut c = Contact {
                a,
                b,
                ..Default::default()
            };
            c.manifold.count = 1;
            c.manifold.points[0].id = id;
            c
        };
        let old = vec![mk(0, 1, 1), mk(0, 3, 2), mk(2, 3, 3)];
        let mut cur = CacheCursor::new(&old);
        assert!(cur.find(0, 0).is_none());
        assert_eq!(cur.find(0, 3).unwrap().points[0].id, 2);
        assert!(cur.find(1, 2).is_none());
        assert_eq!(cur.find(2, 3).unwrap().points[0].id, 3);
        assert!(cur.find(5, 6).is_none());
    }
}
