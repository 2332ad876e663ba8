//! Bodies by creation order, through the public API: the tests build their worlds body
//! by body (or from a scene) and name each by the order it was made in, which
//! `World::bodies` yields.

#![allow(dead_code)]

use sandbox2d::{Body, BodyKey, World};

/// A world's bodies by creation order.
pub trait ByOrder {
    /// The body made `n`th (0: the first) among those still there.
    fn nth_body(&self, n: usize) -> &Body;
    /// The key of the body made `n`th among those still there.
    fn nth_key(&self, n: usize) -> BodyKey;
    /// The key of the body made `n`th, None past the last.
    fn key_at(&self, n: usize) -> Option<BodyKey>;
    /// Where the body named `name` is in creation order.
    fn order_of(&self, name: &str) -> Option<usize>;
    /// Where the body of `key` is in creation order, None for a stale key.
    fn order_of_key(&self, key: BodyKey) -> Option<usize>;
}

impl ByOrder for World {
    fn nth_body(&self, n: usize) -> &Body {
        self.bodies().nth(n).expect("a body made that early").1
    }

    fn nth_key(&self, n: usize) -> BodyKey {
        self.bodies().nth(n).expect("a body made that early").0
    }

    fn key_at(&self, n: usize) -> Option<BodyKey> {
        self.bodies().nth(n).map(|(k, _)| k)
    }

    fn order_of(&self, name: &str) -> Option<usize> {
        self.bodies().position(|(_, b)| b.name == name)
    }

    fn order_of_key(&self, key: BodyKey) -> Option<usize> {
        self.bodies().position(|(k, _)| k == key)
    }
}
