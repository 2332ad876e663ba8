//! A closed one-sided loop as scene-file text, for the tests that race bodies round its
//! inside.

#![allow(dead_code)]

/// The head of a scene file named `name`, with gravity `gravity` along y and a closed
/// one-sided polyline of `sides` sides on a circle of `radius` about the origin
/// (friction 0.1, colliding on its inside); bodies are appended to it.
pub fn one_sided_loop(name: &str, gravity: f32, radius: f32, sides: usize) -> String {
    let points: Vec<String> = (0..sides)
        .map(|k| {
            let a = std::f32::consts::TAU * k as f32 / sides as f32;
            format!("[{}, {}]", radius * a.cos(), radius * a.sin())
        })
        .collect();
    format!(
        "name = \"{name}\"\n[world]\ngravity = [0.0, {gravity:?}]\n\
         [[polyline]]\nloop = true\none_sided = true\nfriction = 0.1\npoints = [{}]\n",
        points.join(", ")
    )
}
