//! Greedy graph colouring of the step's constraints (Box2D's constraint_graph.c, as a
//! pass): each takes the lowest colour neither of its moving bodies uses yet.

#[allow(unused_imports)]
use super::*;

/// How many contacts ahead the colouring asks for the one it will read.
const CONTACT_AHEAD: usize = 8;

/// Colour of a constraint no colour was free for: it gets a wide constraint to itself.
pub(super) const OVERFLOW: usize = 64;

/// What [`color_contacts`] counted.
pub(super) struct Colored {
    /// Contacts per colour.
    pub(super) counts: [u32; OVERFLOW + 1],
    /// Joints per colour.
    pub(super) joint_counts: [u32; OVERFLOW + 1],
    /// Contact points.
    pub(super) points: usize,
    /// Whether some contact is lopsided (looked for only where masses were given).
    pub(super) lopsided: bool,
    /// The depth given, where some contact between two moving bodies overlaps deeper
    /// than it (looked for only where one was given).
    pub(super) deep: Option<f32>,
}

/// Greedy colouring, the joints first (in joint order: `joints` holds each joint's two
/// bodies; their colours go to `joint_colors`), then the contacts in contact order: each
/// takes the lowest colour neither of its moving bodies (`moves`) uses yet, [`OVERFLOW`]
/// where none is free (`body_colors` holds each body's colours while it runs, clear
/// before and after); a body that does not move takes no colour. So a colour's joints
/// and contacts share no moving body, and its joints can be solved beside its contacts
/// (Box2D's constraint graph, where joints and contacts share the colours too). Writes
/// each contact's colour to `colors`, and to
/// `cut_counts` what each colour had counted at the start of each of the `threads` even
/// runs of the contacts but the first (the layout cuts the colours there). With
/// `inv_mass`, also looks for a lopsided contact, and with `deep` for a contact between
/// moving bodies deeper than that (see `SoftSolver::find_direct`): each pass over the
/// contacts reads them from far in the cache.
#[allow(clippy::too_many_arguments)]
pub(super) fn color_contacts(
    contacts: &[Contact],
    joints: &[(u32, u32)],
    moves: &[bool],
    inv_mass: Option<&[(f32, f32)]>,
    deep: Option<f32>,
    threads: usize,
    body_colors: &mut Vec<u64>,
    colors: &mut Vec<u8>,
    joint_colors: &mut Vec<u8>,
    recolor_joints: bool,
    cut_counts: &mut Vec<[u32; OVERFLOW + 1]>,
) -> Colored {
    // every body's colours are clear between colourings (cleared below), so a world of
    // many sleepers and few constraints pays for the few
    body_colors.resize(moves.len(), 0);
    debug_assert!(body_colors.iter().all(|&c| c == 0));
    colors.resize(contacts.len(), 0);
    cut_counts.clear();
    // (kept joints' colours are marked on their bodies only for contacts to avoid)
    let marked = recolor_joints || !contacts.is_empty();
    let joint_counts = if recolor_joints {
        color_joints(joints, moves, body_colors, joint_colors)
    } else if contacts.is_empty() {
        count_colors(joint_colors)
    } else {
        keep_joint_colors(joints, moves, body_colors, joint_colors)
    };
    let mut counts = [0u32; OVERFLOW + 1];
    let (mut points, mut lopsided, mut deep_found) = (0usize, false, false);
    let below = -deep.unwrap_or(f32::INFINITY);
    // plain slices, so the loop keeps its pointers in registers
    let body_colors = &mut body_colors[..];
    for k in 0..threads {
        if k > 0 {
            cut_counts.push(counts);
        }
        let run = parallel::split(contacts.len(), threads, k);
        for (i, (c, out)) in contacts[run.clone()]
            .iter()
            .zip(&mut colors[run.clone()])
            .enumerate()
        {
            prefetch(
                contacts,
                run.start + i + CONTACT_AHEAD,
                std::mem::size_of::<Contact>(),
            );
            let (a, b) = (c.a as usize, c.b as usize);
            let (ma, mb) = (moves[a], moves[b]);
            points += c.manifold.count;
            if let Some(inv_mass) = inv_mass
                && ma
                && mb
            {
                lopsided |= is_lopsided(inv_mass[a].0, inv_mass[b].0);
            }
            if deep.is_some() && ma && mb {
                deep_found |= c.manifold.points().iter().any(|p| p.separation < below);
            }
            let used =
                (if ma { body_colors[a] } else { 0 }) | (if mb { body_colors[b] } else { 0 });
            let color = (!used).trailing_zeros() as usize;
            if color < OVERFLOW {
                let bit = 1u64 << color;
                if ma {
                    body_colors[a] |= bit;
                }
                if mb {
                    body_colors[b] |= bit;
                }
            }
            counts[color] += 1;
            *out = color as u8;
        }
    }
    if marked && 4 * (contacts.len() + joints.len()) < body_colors.len() {
        for &(a, b) in joints {
            body_colors[a as usize] = 0;
            body_colors[b as usize] = 0;
        }
        for c in contacts {
            body_colors[c.a as usize] = 0;
            body_colors[c.b as usize] = 0;
        }
    } else if marked {
        body_colors.fill(0);
    }
    Colored {
        counts,
        joint_counts,
        points,
        lopsided,
        deep: deep.filter(|_| deep_found),
    }
}

/// How many of the kept colours `colors` there are of each colour.
fn count_colors(colors: &[u8]) -> [u32; OVERFLOW + 1] {
    let mut counts = [0u32; OVERFLOW + 1];
    for &c in colors {
        counts[c as usize] += 1;
    }
    counts
}

/// The joints' part of [`color_contacts`] while the joints and which bodies move are as
/// when they were last coloured: their colours kept (`joint_colors`), their bodies'
/// colours marked. Returns the joints per colour.
fn keep_joint_colors(
    joints: &[(u32, u32)],
    moves: &[bool],
    body_colors: &mut [u64],
    joint_colors: &[u8],
) -> [u32; OVERFLOW + 1] {
    let mut counts = [0u32; OVERFLOW + 1];
    for (&(a, b), &color) in joints.iter().zip(joint_colors) {
        let color = color as usize;
        if color < OVERFLOW {
            let bit = 1u64 << color;
            let (a, b) = (a as usize, b as usize);
            if moves[a] {
                body_colors[a] |= bit;
            }
            if moves[b] {
                body_colors[b] |= bit;
            }
        }
        counts[color] += 1;
    }
    counts
}

/// The joints' part of [`color_contacts`]: each joint, in order, takes the lowest colour
/// neither of its moving bodies uses yet (a joint of no moving body takes colour 0: it
/// does nothing, and touches no body that moves). Returns the joints per colour.
fn color_joints(
    joints: &[(u32, u32)],
    moves: &[bool],
    body_colors: &mut [u64],
    joint_colors: &mut Vec<u8>,
) -> [u32; OVERFLOW + 1] {
    let mut counts = [0u32; OVERFLOW + 1];
    joint_colors.clear();
    joint_colors.extend(joints.iter().map(|&(a, b)| {
        let (a, b) = (a as usize, b as usize);
        let (ma, mb) = (moves[a], moves[b]);
        let used = (if ma { body_colors[a] } else { 0 }) | (if mb { body_colors[b] } else { 0 });
        let color = (!used).trailing_zeros() as usize;
        if color < OVERFLOW {
            let bit = 1u64 << color;
            if ma {
                body_colors[a] |= bit;
            }
            if mb {
                body_colors[b] |= bit;
            }
        }
        counts[color] += 1;
        color as u8
    }));
    counts
}
