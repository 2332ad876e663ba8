//! Every refusal of the scene format, one by one: the exact line and column, and a
//! message that names what is wrong.

#[path = "common/bodies.rs"]
mod bodies;
use bodies::ByOrder;
use sandbox2d::scene::{SceneError, load_str};

/// Loads `text` as "bad.toml", which must be refused.
fn refuse(text: &str) -> SceneError {
    match load_str(text, "bad.toml") {
        Ok(scene) => panic!("accepted a bad scene: {scene:?}"),
        Err(e) => e,
    }
}

/// Refused at `line`:`col`, with a message containing each of `needles`.
#[track_caller]
fn check(text: &str, line: usize, col: usize, needles: &[&str]) {
    let e = refuse(text);
    let shown = e.to_string();
    assert_eq!(e.file(), "bad.toml", "{shown}");
    assert_eq!((e.line(), e.column()), (Some(line), Some(col)), "{shown}");
    assert!(
        shown.starts_with(&format!("bad.toml:{line}:{col}: ")),
        "{shown}"
    );
    for n in needles {
        assert!(
            e.message().contains(n),
            "message {:?} should contain {n:?}",
            e.message()
        );
    }
}

/// A one-body scene with the given lines in its `[[body]]` table (from line 3).
fn body(lines: &str) -> String {
    format!("name = \"t\"\n[[body]]\n{lines}\n")
}

#[test]
fn unknown_top_level_key() {
    check(
        "name = \"t\"\ngravty = [0, -10]\n",
        2,
        1,
        &["unknown field", "gravty"],
    );
}

#[test]
fn unknown_key_in_body() {
    check(
        &body("shape = { circle = 1.0 }\nradius = 1.0"),
        4,
        1,
        &["radius"],
    );
}

#[test]
fn unknown_key_in_shape() {
    check(&body("shape = { circel = 1.0 }"), 3, 11, &["circel"]);
}

#[test]
fn unknown_key_in_world_drag() {
    check(
        "name = \"t\"\n[world.drag]\nlinaer = 0.1\n",
        3,
        1,
        &["linaer"],
    );
}

#[test]
fn unknown_key_in_solver() {
    check(
        "name = \"t\"\n[solver]\nitertions = 5\n",
        3,
        1,
        &["itertions"],
    );
}

#[test]
fn unknown_key_in_joint_motor() {
    let text = "name = \"t\"\n[[body]]\nname = \"a\"\nshape = { circle = 1 }\n[[body]]\nname = \"b\"\nshape = { circle = 1 }\n[[joint]]\ntype = \"hinge\"\nbodies = [\"a\", \"b\"]\nmotor = { speed = 1, max_torqe = 2 }\n";
    check(text, 11, 22, &["max_torqe"]);
}

#[test]
fn missing_name() {
    check(
        "[[body]]\nshape = { circle = 1.0 }\n",
        1,
        1,
        &["missing field", "name"],
    );
}

#[test]
fn empty_name() {
    check("name = \"  \"\n", 1, 8, &["name must not be empty"]);
}

#[test]
fn missing_shape_points_at_the_table() {
    check(
        "name = \"t\"\n\n[[body]]\nname = \"ball\"\n",
        3,
        1,
        &["missing field", "shape"],
    );
}

#[test]
fn wrong_type() {
    check(
        "name = \"t\"\n[world]\ngravity = \"down\"\n",
        3,
        11,
        &["invalid type", "string"],
    );
}

#[test]
fn wrong_array_length() {
    check(
        "name = \"t\"\n[world]\ngravity = [0, -10, 3]\n",
        3,
        11,
        &["invalid length 3", "2 elements"],
    );
}

#[test]
fn negative_count_is_a_type_error() {
    check("name = \"t\"\n[[stack]]\ncount = -1\n", 3, 9, &["-1"]);
}

#[test]
fn syntax_error() {
    let e = refuse("name = \"t\"\nfoo = \n");
    assert_eq!(e.line(), Some(2), "{e}");
}

#[test]
fn duplicate_toml_key() {
    check("name = \"t\"\nname = \"u\"\n", 2, 1, &["duplicate key"]);
}

#[test]
fn nan_number() {
    check(
        &body("shape = { circle = 1.0 }\nfriction = nan"),
        4,
        12,
        &["friction", "finite", "NaN"],
    );
}

#[test]
fn infinite_number() {
    check(
        "name = \"t\"\n[world]\ngravity = [0, -inf]\n",
        3,
        15,
        &["gravity", "finite", "-inf"],
    );
}

#[test]
fn overflowing_number_is_infinite() {
    check(
        &body("shape = { circle = 1e300 }"),
        3,
        20,
        &["circle radius", "finite", "inf"],
    );
}

#[test]
fn circle_radius_not_positive() {
    check(
        &body("name = \"ball\"\nshape = { circle = -0.5 }"),
        4,
        20,
        &["body \"ball\"", "radius", "> 0", "-0.5"],
    );
}

#[test]
fn box_size_zero() {
    check(
        &body("shape = { box = [0.0, 1.0] }"),
        3,
        18,
        &["box", "size", "> 0", "[0, 1]"],
    );
}

#[test]
fn box_size_is_refused_on_static_bodies_too() {
    check(
        &body("type = \"static\"\nshape = { box = [4.0, -1.0] }"),
        4,
        23,
        &["box", "[4, -1]"],
    );
}

#[test]
fn density_not_positive_on_dynamic() {
    check(
        &body("shape = { circle = 1.0 }\ndensity = 0.0"),
        4,
        11,
        &["density", "> 0", "dynamic", "got 0"],
    );
}

#[test]
fn mass_not_positive_on_dynamic() {
    check(
        &body("shape = { circle = 1.0 }\nmass = -2.0"),
        4,
        8,
        &["mass", "> 0", "-2"],
    );
}

#[test]
fn static_and_kinematic_bodies_may_have_any_density() {
    let s = load_str(
        &body("type = \"static\"\nshape = { circle = 1.0 }\ndensity = 0.0"),
        "ok.toml",
    )
    .unwrap();
    assert_eq!(s.world.bodies[0].density, 0.0);
    let s = load_str(
        &body("type = \"kinematic\"\nshape = { circle = 1.0 }\nmass = -1.0"),
        "ok.toml",
    )
    .unwrap();
    assert_eq!(s.world.bodies[0].mass, Some(-1.0));
}

#[test]
fn density_and_mass_together() {
    check(
        &body("shape = { circle = 1.0 }\ndensity = 2.0\nmass = 3.0"),
        5,
        8,
        &["density", "mass", "not both"],
    );
}

#[test]
fn polygon_with_too_few_distinct_points() {
    check(
        &body("shape = { polygon = [[0, 0], [1, 0], [1, 0], [0, 0]] }"),
        3,
        21,
        &["polygon", "at least 3 distinct points", "got 2"],
    );
}

#[test]
fn polygon_with_no_area() {
    check(
        &body("shape = { polygon = [[0, 0], [1, 1], [2, 2], [3, 3]] }"),
        3,
        21,
        &["polygon", "no area", "collinear"],
    );
}

#[test]
fn polygon_point_not_finite() {
    check(
        &body("shape = { polygon = [[0, 0], [1, nan], [0, 1]] }"),
        3,
        34,
        &["polygon point", "finite"],
    );
}

#[test]
fn particle_with_a_box() {
    check(
        &body("model = \"particle\"\nshape = { box = [1, 1] }"),
        4,
        9,
        &["particle", "circle", "box"],
    );
}

#[test]
fn particle_in_a_grid_with_a_polygon() {
    let text = "name = \"t\"\n[[grid]]\nrows = 2\ncolumns = 2\nspacing = [1, 1]\nmodel = \"particle\"\nshape = { polygon = [[0, 0], [1, 0], [0, 1]] }\n";
    check(text, 7, 9, &["grid0", "particle", "circle", "polygon"]);
}

#[test]
fn duplicate_body_names() {
    let text = "name = \"t\"\n[[body]]\nname = \"ball\"\nshape = { circle = 1 }\n[[body]]\nname = \"ball\"\nshape = { circle = 1 }\n";
    check(text, 6, 8, &["duplicate body name", "\"ball\"", "line 3"]);
}

#[test]
fn duplicate_of_a_generated_name() {
    // The pyramid's fourth box is named pyramid0_3: the later table is refused.
    let text = "name = \"t\"\n[[body]]\nname = \"pyramid0_3\"\nshape = { circle = 1 }\n[[pyramid]]\nbase = 3\n";
    check(text, 5, 1, &["duplicate body name", "pyramid0_3"]);
}

#[test]
fn force_naming_a_missing_body() {
    let text = "name = \"t\"\n[[body]]\nname = \"cart\"\nshape = { box = [1, 1] }\n[[force]]\nbody = \"crat\"\nforce = [1, 0]\n";
    check(text, 6, 8, &["force", "no body named", "\"crat\""]);
}

const TWO_BODIES: &str = "name = \"t\"\n[[body]]\nname = \"a\"\nshape = { circle = 1 }\n[[body]]\nname = \"b\"\nshape = { circle = 1 }\n";

/// `TWO_BODIES` and a joint table with these lines, from line 9.
fn joint(lines: &str) -> String {
    format!("{TWO_BODIES}[[joint]]\n{lines}\n")
}

#[test]
fn joint_naming_a_missing_body() {
    check(
        &joint("type = \"hinge\"\nbodies = [\"a\", \"c\"]"),
        10,
        16,
        &["no body named", "\"c\""],
    );
}

#[test]
fn joint_joining_a_body_to_itself() {
    check(
        &joint("type = \"weld\"\nbodies = [\"a\", \"a\"]"),
        10,
        10,
        &["itself", "\"a\""],
    );
}

#[test]
fn joint_limits_min_above_max() {
    check(
        &joint("type = \"hinge\"\nbodies = [\"a\", \"b\"]\nlimits = [1.5, -1.0]"),
        11,
        10,
        &["limits", "min <= max", "[1.5, -1]"],
    );
}

#[test]
fn prismatic_axis_of_zero_length() {
    check(
        &joint("type = \"prismatic\"\nbodies = [\"a\", \"b\"]\naxis = [0, 0]"),
        11,
        8,
        &["axis", "non-zero length"],
    );
}

#[test]
fn joint_break_force_not_positive() {
    check(
        &joint("type = \"hinge\"\nbodies = [\"a\", \"b\"]\nbreak_force = 0"),
        11,
        15,
        &["break_force", "> 0", "got 0"],
    );
}

#[test]
fn joint_break_torque_not_finite() {
    check(
        &joint("type = \"weld\"\nbodies = [\"a\", \"b\"]\nbreak_torque = nan"),
        11,
        16,
        &["break_torque"],
    );
}

#[test]
fn joint_break_thresholds_load() {
    let scene = sandbox2d::scene::load_str(
        &joint("type = \"hinge\"\nbodies = [\"a\", \"b\"]\nbreak_force = 50\nbreak_torque = 7.5"),
        "ok.toml",
    )
    .unwrap();
    let j = &scene.world.joints[0];
    assert_eq!((j.break_force, j.break_torque), (Some(50.0), Some(7.5)));
}

#[test]
fn negative_compliance() {
    check(
        &joint("type = \"distance\"\nbodies = [\"a\", \"b\"]\ncompliance = -1e-3"),
        11,
        14,
        &["compliance", ">= 0", "-0.001"],
    );
}

#[test]
fn unknown_joint_type_lists_the_allowed() {
    check(
        &joint("type = \"hindge\"\nbodies = [\"a\", \"b\"]"),
        9,
        8,
        &[
            "unknown type \"hindge\"",
            "\"distance\", \"hinge\", \"prismatic\", \"weld\"",
        ],
    );
}

#[test]
fn key_that_does_not_apply_to_the_joint_type() {
    check(
        &joint("type = \"weld\"\nbodies = [\"a\", \"b\"]\nmotor = { speed = 1, max_torque = 2 }"),
        11,
        9,
        &["motor", "weld"],
    );
}

#[test]
fn rope_refuses_limits() {
    check(
        &joint("type = \"rope\"\nbodies = [\"a\", \"b\"]\nlimits = [0, 1]"),
        11,
        10,
        &[
            "rope joint \"a\"-\"b\"",
            "`limits` does not apply to a rope joint",
            "max length",
        ],
    );
}

#[test]
fn rope_refuses_the_keys_it_does_not_take() {
    for (line, key) in [
        ("anchor = [0, 0]", "anchor"),
        ("axis = [1, 0]", "axis"),
        ("motor = { speed = 1, max_force = 2 }", "motor"),
        ("servo = { target = 1 }", "servo"),
        ("compliance = 1e-3", "compliance"),
    ] {
        let col = line.find('=').unwrap() + 3;
        check(
            &joint(&format!(
                "type = \"rope\"\nbodies = [\"a\", \"b\"]\nlength = 1\n{line}"
            )),
            12,
            col,
            &[&format!("`{key}` does not apply to a rope joint")],
        );
    }
}

#[test]
fn rope_length_not_positive() {
    for (v, got) in [("0.0", "got 0"), ("-1.5", "got -1.5")] {
        check(
            &joint(&format!(
                "type = \"rope\"\nbodies = [\"a\", \"b\"]\nlength = {v}"
            )),
            11,
            10,
            &["rope joint", "length must be > 0", got],
        );
    }
}

#[test]
fn rope_of_zero_length_at_creation() {
    // no `length`: the default is the anchors' distance, here the two bodies' centres,
    // which coincide
    check(
        &joint("type = \"rope\"\nbodies = [\"a\", \"b\"]"),
        10,
        10,
        &["rope joint", "length must be > 0", "give `length`"],
    );
}

#[test]
fn hinge_motor_takes_max_torque() {
    check(
        &joint("type = \"hinge\"\nbodies = [\"a\", \"b\"]\nmotor = { speed = 1, max_force = 2 }"),
        11,
        34,
        &["max_torque", "max_force"],
    );
}

#[test]
fn dt_not_positive() {
    check(
        "name = \"t\"\n[solver]\ndt = 0.0\n",
        3,
        6,
        &["solver", "dt", "in (0, 1]", "got 0"],
    );
}

#[test]
fn iterations_zero() {
    check(
        "name = \"t\"\n[solver]\niterations = 0\n",
        3,
        14,
        &["iterations", "from 1 to 10000", "got 0"],
    );
}

#[test]
fn substeps_zero() {
    check(
        "name = \"t\"\n[solver]\nkind = \"xpbd\"\nsubsteps = 0\n",
        4,
        12,
        &["substeps", "from 1 to 1000"],
    );
}

#[test]
fn negative_slop() {
    check(
        "name = \"t\"\n[solver]\nslop = -0.01\n",
        3,
        8,
        &["slop", ">= 0", "-0.01"],
    );
}

#[test]
fn baumgarte_outside_unit_interval() {
    check(
        "name = \"t\"\n[solver]\nbaumgarte = 1.5\n",
        3,
        13,
        &["baumgarte", "[0, 1]", "1.5"],
    );
}

#[test]
fn negative_tolerance() {
    check(
        "name = \"t\"\n[solver]\ntolerance = -1e-4\n",
        3,
        13,
        &["tolerance", ">= 0"],
    );
}

#[test]
fn unknown_solver_kind_lists_the_allowed() {
    check(
        "name = \"t\"\n[solver]\nkind = \"gs\"\n",
        3,
        8,
        &["unknown kind \"gs\"", "\"pgs\", \"xpbd\""],
    );
}

#[test]
fn negative_friction() {
    check(
        &body("shape = { circle = 1.0 }\nfriction = -0.1"),
        4,
        12,
        &["friction", ">= 0", "-0.1"],
    );
}

#[test]
fn restitution_above_one() {
    check(
        &body("shape = { circle = 1.0 }\nrestitution = 1.2"),
        4,
        15,
        &["restitution", "[0, 1]", "1.2"],
    );
}

#[test]
fn generator_restitution_below_zero() {
    check(
        "name = \"t\"\n[[stack]]\ncount = 2\nrestitution = -0.5\n",
        4,
        15,
        &["stack0", "restitution", "-0.5"],
    );
}

#[test]
fn unknown_body_type_lists_the_allowed() {
    check(
        &body("type = \"dynamc\"\nshape = { circle = 1.0 }"),
        3,
        8,
        &[
            "unknown type \"dynamc\"",
            "\"static\", \"dynamic\", \"kinematic\"",
        ],
    );
}

#[test]
fn unknown_model_lists_the_allowed() {
    check(
        &body("model = \"point\"\nshape = { circle = 1.0 }"),
        3,
        9,
        &["unknown model \"point\"", "\"rigid\", \"particle\""],
    );
}

#[test]
fn shape_with_no_key() {
    check(
        &body("shape = {}"),
        3,
        9,
        &["shape", "none of", "exactly one"],
    );
}

#[test]
fn shape_with_two_keys() {
    check(
        &body("shape = { box = [1, 1], circle = 1.0 }"),
        3,
        9,
        &["box and circle", "exactly one"],
    );
}

#[test]
fn bad_colour() {
    check(
        &body("shape = { circle = 1.0 }\ncolor = \"#12345g\""),
        4,
        9,
        &["color", "#rrggbb", "#12345g"],
    );
    check(
        &body("shape = { circle = 1.0 }\ncolor = \"red\""),
        4,
        9,
        &["color", "\"red\""],
    );
}

#[test]
fn colours_are_parsed() {
    let s = load_str(
        &body("shape = { circle = 1.0 }\ncolor = \"#ff8000\""),
        "ok.toml",
    )
    .unwrap();
    assert_eq!(s.world.bodies[0].color, Some([255, 128, 0, 255]));
    let s = load_str(
        &body("shape = { circle = 1.0 }\ncolor = \"#FF800080\""),
        "ok.toml",
    )
    .unwrap();
    assert_eq!(s.world.bodies[0].color, Some([255, 128, 0, 128]));
}

#[test]
fn camera_pixels_per_meter_not_positive() {
    check(
        "name = \"t\"\n[camera]\npixels_per_meter = 0\n",
        3,
        20,
        &["pixels_per_meter", "> 0"],
    );
}

#[test]
fn camera_size_with_a_zero() {
    // at the element that is out of range
    check(
        "name = \"t\"\n[camera]\nsize = [1280, 0]\n",
        3,
        15,
        &["size", "[1280, 0]"],
    );
}

#[test]
fn generator_counts_of_zero() {
    check(
        "name = \"t\"\n[[pyramid]]\nbase = 0\n",
        3,
        8,
        &["pyramid0", "base", ">= 1"],
    );
    check(
        "name = \"t\"\n[[stack]]\ncount = 0\n",
        3,
        9,
        &["stack0", "count", ">= 1"],
    );
    check(
        "name = \"t\"\n[[grid]]\nrows = 3\ncolumns = 0\nspacing = [1, 1]\nshape = { circle = 0.1 }\n",
        4,
        11,
        &["grid0", "columns", ">= 1"],
    );
    check(
        "name = \"t\"\n[[chain]]\nlinks = 0\nlink = [1, 0.2]\nanchor = [0, 5]\n",
        3,
        9,
        &["chain0", "links", ">= 1"],
    );
}

#[test]
fn generator_too_large() {
    check(
        "name = \"t\"\n[[pyramid]]\nbase = 100000\n",
        3,
        8,
        &["pyramid0", "5000050000 bodies"],
    );
}

#[test]
fn chain_direction_of_zero_length() {
    check(
        "name = \"t\"\n[[chain]]\nlinks = 3\nlink = [1, 0.2]\nanchor = [0, 5]\ndirection = [0, 0]\n",
        6,
        13,
        &["chain0", "direction", "non-zero"],
    );
}

#[test]
fn chain_unknown_joint_lists_the_allowed() {
    check(
        "name = \"t\"\n[[chain]]\nlinks = 3\nlink = [1, 0.2]\nanchor = [0, 5]\njoint = \"rope\"\n",
        6,
        9,
        &["unknown joint \"rope\"", "\"hinge\", \"distance\""],
    );
}

#[test]
fn drag_needs_both_fluid_terms() {
    check(
        "name = \"t\"\n[world.drag]\nfluid_density = 1.225\n",
        3,
        17,
        &["fluid_density", "drag_coefficient"],
    );
}

#[test]
fn negative_drag() {
    check(
        "name = \"t\"\n[world.drag]\nlinear = -1\n",
        3,
        10,
        &["linear", ">= 0"],
    );
}

#[test]
fn file_that_cannot_be_read() {
    let path = std::path::Path::new("/nonexistent/dir/scene.toml");
    let e = sandbox2d::scene::load_file(path).unwrap_err();
    assert_eq!(e.file(), "/nonexistent/dir/scene.toml");
    assert_eq!((e.line(), e.column()), (None, None));
    assert!(
        e.to_string()
            .starts_with("/nonexistent/dir/scene.toml: cannot read: "),
        "{e}"
    );
}

#[test]
fn columns_count_characters_not_bytes() {
    // "é" is two bytes: the value starts at character 14, byte 15.
    check(
        "name = \"t\"\n[[body]]\nname = \"é\"\nshape = { circle = 1 }\nfriction = -1\n",
        5,
        12,
        &["body \"é\"", "friction"],
    );
    check("name = \"t\" # é\n[solver]\ndt = -1 # é\n", 3, 6, &["dt"]);
    check("name = \"té\"\n[solver]\nslop = -1\n", 3, 8, &["slop"]);
    check("[[body]]\nname = \"é\"\n x = 1", 3, 2, &["x"]);
}

#[test]
fn arbitrary_garbage_never_panics() {
    for text in [
        "",
        "\0",
        "name = 1",
        "[[body]]\n[[body]]",
        "name = \"t\"\nbody = 5",
        "name=\"t\"\n[[joint]]\ntype=\"hinge\"\nbodies=[]",
    ] {
        assert!(load_str(text, "bad.toml").is_err(), "{text:?}");
    }
}

// ---------------------------------------------------------------------------
// Scenes that load: built-ins, generators, defaults, `load`.

use glam::Vec2;
use sandbox2d::scene::{builtin, builtin_description, builtin_names, load, load_file};
use sandbox2d::{BodyModel, BodyType, JointKind, ShapeDef, SolverKind};

#[test]
fn every_builtin_parses_and_has_a_description() {
    let names = builtin_names();
    // the built-in scenes, listed sorted
    let wanted = [
        "ball_and_chain",
        "ball_stack",
        "bounce",
        "bridge",
        "car",
        "chain",
        "compound",
        "double_pendulum",
        "friction_ramp",
        "joint_grid",
        "joints",
        "large_pyramid",
        "machines",
        "multi_pendulum",
        "newtons_cradle",
        "particles",
        "pendulum",
        "pyramid",
        "pyramid_throw",
        "ragdoll",
        "rope",
        "sensor_gate",
        "shapes",
        "stack",
        "vacuum_vs_fluid",
    ];
    assert_eq!(names, wanted);
    for name in names {
        let scene = builtin(name)
            .expect("listed")
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(scene.source, format!("builtin:{name}"));
        assert!(!scene.world.bodies.is_empty(), "{name}");
        let d = scene.description.clone().expect("a description");
        assert!(!d.is_empty());
        assert_eq!(builtin_description(name), Some(d));
    }
    assert!(builtin("no_such_scene").is_none());
    assert_eq!(builtin_description("no_such_scene"), None);
}

#[test]
fn large_pyramid_is_the_benchmark() {
    let s = builtin("large_pyramid").unwrap().unwrap();
    let w = &s.world;
    assert_eq!(w.bodies.len(), 5051);
    assert_eq!(w.gravity, Some(Vec2::new(0.0, -10.0)));
    assert!((w.solver.resolve().dt - 1.0 / 60.0).abs() < 1e-7);
    assert_eq!(w.solver.resolve().kind, SolverKind::Soft);
    assert_eq!(w.drag, None);
    let ground = &w.bodies[0];
    assert_eq!(ground.body_type, BodyType::Static);
    assert_eq!(
        ground.shape,
        ShapeDef::Box {
            width: 200.0,
            height: 2.0
        }
    );
    assert_eq!(ground.position, Vec2::new(0.0, -1.0));
    let boxes = &w.bodies[1..];
    for b in boxes {
        assert_eq!(b.body_type, BodyType::Dynamic);
        assert_eq!(
            b.shape,
            ShapeDef::Box {
                width: 1.0,
                height: 1.0
            }
        );
        assert_eq!(
            (b.density, b.friction, b.restitution, b.mass),
            (1.0, 0.6, 0.0, None)
        );
    }
    // Bottom row, left to right, then up: the benchmark's formula with h = 0.5.
    assert_eq!(boxes[0].name, "pyramid0_0");
    assert_eq!(boxes[0].position, Vec2::new(-49.5, 0.5));
    assert_eq!(boxes[1].position, Vec2::new(-48.5, 0.5));
    assert_eq!(boxes[99].position, Vec2::new(49.5, 0.5));
    assert_eq!(boxes[100].position, Vec2::new(-49.0, 1.5));
    assert_eq!(boxes[5049].name, "pyramid0_5049");
    assert_eq!(boxes[5049].position, Vec2::new(0.0, 99.5));
    // Every box against x = (i + 1) h + 2 h (j - i) - h base, y = (2 i + 1) h.
    let (h, base) = (0.5f32, 100);
    let mut k = 0;
    for i in 0..base {
        for j in i..base {
            let x = (i + 1) as f32 * h + 2.0 * h * (j - i) as f32 - h * base as f32;
            let y = (2 * i + 1) as f32 * h;
            assert_eq!(boxes[k].position, Vec2::new(x, y), "row {i} box {j}");
            k += 1;
        }
    }
}

#[test]
fn pyramid_has_base_20() {
    let s = builtin("pyramid").unwrap().unwrap();
    assert_eq!(s.world.bodies.len(), 211);
    assert_eq!(s.world.bodies[1].position, Vec2::new(-9.5, 0.5));
    assert_eq!(s.world.bodies[210].position, Vec2::new(0.0, 19.5));
}

#[test]
fn demo_scenes_use_rubber_particles_in_air() {
    for (name, balls) in [("ball_stack", 10), ("particles", 50)] {
        let s = builtin(name).unwrap().unwrap();
        let particles: Vec<_> = s
            .world
            .bodies
            .iter()
            .filter(|b| b.model == BodyModel::Particle)
            .collect();
        assert_eq!(particles.len(), balls, "{name}");
        for p in &particles {
            assert_eq!(p.density, 1522.0);
            assert!(
                matches!(p.shape, ShapeDef::Circle { radius } if (0.05..=0.1).contains(&radius))
            );
            // Inside the 2 m x 2 m box.
            assert!(
                p.position.x.abs() < 1.0 && p.position.y > 0.0 && p.position.y < 2.0,
                "{name} {p:?}"
            );
        }
        let drag = s.world.drag.expect("air");
        assert_eq!((drag.fluid_density, drag.drag_coefficient), (1.225, 0.47));
        assert_eq!(
            s.world
                .bodies
                .iter()
                .filter(|b| b.body_type == BodyType::Static)
                .count(),
            4
        );
    }
}

#[test]
fn stack_is_15_boxes_on_the_ground() {
    let s = builtin("stack").unwrap().unwrap();
    assert_eq!(s.world.bodies.len(), 16);
    for (k, b) in s.world.bodies[1..].iter().enumerate() {
        assert_eq!(b.position, Vec2::new(0.0, k as f32 + 0.5));
        assert_eq!(b.name, format!("stack0_{k}"));
    }
}

#[test]
fn bodies_are_created_in_file_order_with_generators_in_place() {
    let text = "name = \"order\"
[[body]]
name = \"first\"
shape = { circle = 1 }

[[stack]]
count = 2
origin = [5, 0]

[[body]]
name = \"middle\"
shape = { circle = 1 }

[[pyramid]]
base = 2

[[stack]]
count = 1
box = [2, 4]
offset = 1.0

[[body]]
shape = { circle = 1 }
";
    let s = load_str(text, "order.toml").unwrap();
    let names: Vec<&str> = s.world.bodies.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "first",
            "stack0_0",
            "stack0_1",
            "middle",
            "pyramid0_0",
            "pyramid0_1",
            "pyramid0_2",
            "stack1_0",
            "body2"
        ]
    );
    assert_eq!(s.world.bodies[2].position, Vec2::new(5.0, 1.5));
    assert_eq!(s.world.bodies[6].position, Vec2::new(0.0, 1.5));
    assert_eq!(s.world.bodies[7].position, Vec2::new(0.0, 2.0));
}

#[test]
fn defaults_where_keys_are_absent() {
    let s = load_str(
        "name = \"d\"\n[[body]]\nshape = { circle = 0.5 }\n",
        "d.toml",
    )
    .unwrap();
    let b = &s.world.bodies[0];
    assert_eq!(b.name, "body0");
    assert_eq!(
        (b.body_type, b.model),
        (BodyType::Dynamic, BodyModel::Rigid)
    );
    assert_eq!(
        (b.density, b.mass, b.friction, b.restitution),
        (1.0, None, 0.6, 0.0)
    );
    assert_eq!(
        (b.position, b.angle, b.velocity, b.angular_velocity),
        (Vec2::ZERO, 0.0, Vec2::ZERO, 0.0)
    );
    assert_eq!(s.world.gravity, None);
    assert_eq!(s.world.drag, None);
    assert_eq!(s.world.solver, Default::default());
    assert_eq!(s.camera, Default::default());
    assert_eq!(s.description, None);
}

#[test]
fn every_key_reaches_the_defs() {
    let text = r##"name = "all"
description = "every key"
[world]
gravity = [0, -9.81]
[world.drag]
linear = 0.1
quadratic = 0.2
fluid_density = 1.225
drag_coefficient = 0.47
[solver]
kind = "xpbd"
dt = 0.01
substeps = 8
iterations = 2
tolerance = 0.0
warm_start = false
baumgarte = 0.3
slop = 0.01
split_impulse = false
restitution_threshold = 0.5
[camera]
center = [1, 2]
pixels_per_meter = 20
size = [640, 480]
[[body]]
name = "ground"
type = "static"
shape = { polygon = [[0, 0], [4, 0], [0, 1]] }
[[body]]
name = "cart"
type = "kinematic"
model = "rigid"
shape = { box = [2, 1] }
position = [1, 2]
angle = 0.5
velocity = [3, 4]
angular_velocity = 1.5
mass = 7
friction = 0.3
restitution = 0.4
color = "#0a0b0c"
[[force]]
body = "cart"
force = [10, 0]
point = [0, 0.5]
[[joint]]
type = "prismatic"
bodies = ["ground", "cart"]
anchor = [1, 2]
axis = [1, 0]
limits = [-1, 1]
motor = { speed = 2, max_force = 50 }
servo = { target = 0.5 }
compliance = 1e-4
damping = { linear = 0.1, angular = 0.2 }
collide_connected = true
[[joint]]
type = "distance"
bodies = ["cart", "ground"]
anchors = [[1, 2], [0, 0]]
length = 2.5
limits = [0, 3]
"##;
    let s = load_str(text, "all.toml").unwrap();
    assert_eq!(s.description.as_deref(), Some("every key"));
    let w = &s.world;
    assert_eq!(w.gravity, Some(Vec2::new(0.0, -9.81)));
    let d = w.drag.unwrap();
    assert_eq!(
        (d.linear, d.quadratic, d.fluid_density, d.drag_coefficient),
        (0.1, 0.2, 1.225, 0.47)
    );
    let r = w.solver.resolve();
    assert_eq!(r.kind, SolverKind::Xpbd);
    assert_eq!(
        (r.dt, r.substeps, r.iterations, r.tolerance),
        (0.01, 8, 2, 0.0)
    );
    assert_eq!(
        (
            r.warm_start,
            r.baumgarte,
            r.slop,
            r.split_impulse,
            r.restitution_threshold
        ),
        (false, 0.3, 0.01, false, 0.5)
    );
    assert_eq!(
        (s.camera.center, s.camera.pixels_per_meter, s.camera.size),
        (Vec2::new(1.0, 2.0), 20.0, [640, 480])
    );
    let cart = &w.bodies[1];
    assert_eq!(cart.body_type, BodyType::Kinematic);
    assert_eq!(
        cart.shape,
        ShapeDef::Box {
            width: 2.0,
            height: 1.0
        }
    );
    assert_eq!(
        (
            cart.position,
            cart.angle,
            cart.velocity,
            cart.angular_velocity
        ),
        (Vec2::new(1.0, 2.0), 0.5, Vec2::new(3.0, 4.0), 1.5)
    );
    assert_eq!(
        (cart.mass, cart.friction, cart.restitution, cart.color),
        (Some(7.0), 0.3, 0.4, Some([10, 11, 12, 255]))
    );
    assert_eq!(w.forces.len(), 1);
    assert_eq!(
        (w.forces[0].body, w.forces[0].force, w.forces[0].point),
        (1, Vec2::new(10.0, 0.0), Vec2::new(0.0, 0.5))
    );
    let p = &w.joints[0];
    assert_eq!(
        (p.kind, p.bodies, p.anchor, p.axis, p.limits),
        (
            JointKind::Prismatic,
            [0, 1],
            Some(Vec2::new(1.0, 2.0)),
            Some(Vec2::X),
            Some([-1.0, 1.0])
        )
    );
    let m = p.motor.unwrap();
    assert_eq!(
        (m.speed, m.max_force, p.servo.unwrap().target),
        (2.0, 50.0, 0.5)
    );
    assert_eq!(
        (
            p.compliance,
            p.damping.linear,
            p.damping.angular,
            p.collide_connected
        ),
        (1e-4, 0.1, 0.2, true)
    );
    let q = &w.joints[1];
    assert_eq!(
        (q.kind, q.bodies, q.anchors, q.length, q.limits),
        (
            JointKind::Distance,
            [1, 0],
            Some([Vec2::new(1.0, 2.0), Vec2::ZERO]),
            Some(2.5),
            Some([0.0, 3.0])
        )
    );
    assert!(!q.collide_connected);
}

#[test]
fn chain_makes_anchor_links_end_and_joints() {
    let text = "name = \"c\"
[[chain]]
links = 4
link = [0.5, 0.125]
anchor = [0, 20]
direction = [1, 0]
joint = \"hinge\"
end = { shape = { circle = 1.0 }, density = 2.0 }
[[force]]
body = \"chain0_end\"
force = [0, -1]
";
    let s = load_str(text, "c.toml").unwrap();
    let w = &s.world;
    let names: Vec<&str> = w.bodies.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "chain0_anchor",
            "chain0_0",
            "chain0_1",
            "chain0_2",
            "chain0_3",
            "chain0_end"
        ]
    );
    assert_eq!(w.bodies[0].body_type, BodyType::Static);
    assert_eq!(w.bodies[1].position, Vec2::new(0.25, 20.0));
    assert_eq!(w.bodies[4].position, Vec2::new(1.75, 20.0));
    assert_eq!(w.bodies[5].position, Vec2::new(3.0, 20.0));
    assert_eq!(w.bodies[5].density, 2.0);
    assert_eq!(w.joints.len(), 5);
    for (i, j) in w.joints.iter().enumerate() {
        assert_eq!(j.kind, JointKind::Hinge);
        assert_eq!(j.bodies, [i, i + 1]);
        assert_eq!(j.anchor, Some(Vec2::new(0.5 * i as f32, 20.0)));
    }
    assert_eq!(w.forces[0].body, 5);

    let s = load_str(&text.replace("\"hinge\"", "\"distance\""), "c.toml").unwrap();
    let j = &s.world.joints[1];
    assert_eq!(j.kind, JointKind::Distance);
    assert_eq!(
        j.anchors,
        Some([Vec2::new(0.25, 20.0), Vec2::new(0.75, 20.0)])
    );
    assert_eq!(j.length, Some(0.5));
}

#[test]
fn grid_places_row_by_row() {
    let text = "name = \"g\"\n[[grid]]\nrows = 2\ncolumns = 3\nspacing = [0.5, 0.25]\norigin = [1, 2]\nshape = { circle = 0.1 }\nmodel = \"particle\"\ntype = \"kinematic\"\n";
    let s = load_str(text, "g.toml").unwrap();
    let b = &s.world.bodies;
    assert_eq!(b.len(), 6);
    assert_eq!(
        (b[1].name.as_str(), b[1].position),
        ("grid0_1", Vec2::new(1.5, 2.0))
    );
    assert_eq!(
        (b[5].name.as_str(), b[5].position),
        ("grid0_5", Vec2::new(2.0, 2.25))
    );
    assert!(
        b.iter()
            .all(|b| b.model == BodyModel::Particle && b.body_type == BodyType::Kinematic)
    );
}

#[test]
fn joints_and_forces_may_name_bodies_declared_later() {
    let text = "name = \"t\"\n[[joint]]\ntype = \"weld\"\nbodies = [\"a\", \"pyramid0_0\"]\n[[body]]\nname = \"a\"\nshape = { circle = 1 }\n[[pyramid]]\nbase = 1\n";
    let s = load_str(text, "t.toml").unwrap();
    assert_eq!(s.world.joints[0].bodies, [0, 1]);
}

#[test]
fn load_takes_a_builtin_name_or_a_path() {
    let s = load("stack").unwrap();
    assert_eq!(s.source, "builtin:stack");
    let dir = std::env::temp_dir().join(format!("sandbox2d-scene-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("mine.toml");
    std::fs::write(&path, "name = \"mine\"\n[[body]]\nshape = { circle = 1 }\n").unwrap();
    let by_str = load(path.to_str().unwrap()).unwrap();
    assert_eq!(by_str.name, "mine");
    assert_eq!(by_str.source, path.display().to_string());
    assert_eq!(load_file(&path).unwrap(), by_str);
    std::fs::write(&path, "name = \"mine\"\n[[body]]\nshape = { circle = 0 }\n").unwrap();
    let e = load(path.to_str().unwrap()).unwrap_err();
    assert_eq!(e.file(), path.display().to_string());
    assert_eq!((e.line(), e.column()), (Some(3), Some(20)));
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(
        load("no_such_scene_or_file")
            .unwrap_err()
            .to_string()
            .contains("cannot read")
    );
}

// ---------------------------------------------------------------------------
// What the world derives at build time is checked at load, and refused at
// the value that caused it; names are quoted with escapes; limits are per file.

#[test]
fn polygon_of_16_vertices_loads_and_builds() {
    let points: Vec<String> = (0..16)
        .map(|i| {
            let a = i as f32 * std::f32::consts::TAU / 16.0;
            format!("[{}, {}]", a.cos(), a.sin())
        })
        .collect();
    let text = body(&format!("shape = {{ polygon = [{}] }}", points.join(", ")));
    let sc = load_str(&text, "ok.toml").unwrap();
    let w = sandbox2d::World::from_def(&sc.world, sc.world.solver.resolve()).unwrap();
    match &w.nth_body(0).shape {
        sandbox2d::shape::Shape::Polygon(p) => assert_eq!(p.count, 16),
        s => panic!("{s:?}"),
    }
}

#[test]
fn polygon_hull_of_more_than_16_vertices_is_refused_at_the_polygon() {
    let points: Vec<String> = (0..20)
        .map(|i| {
            let a = i as f32 * std::f32::consts::TAU / 20.0;
            format!("[{}, {}]", a.cos(), a.sin())
        })
        .collect();
    let text = body(&format!("shape = {{ polygon = [{}] }}", points.join(", ")));
    check(
        &text,
        3,
        21,
        &["body \"body0\"", "20 vertices", "at most 16"],
    );
}

#[test]
fn polygon_with_too_many_points_is_refused() {
    let points: Vec<String> = (0..65).map(|i| format!("[{}, {}]", i % 2, i / 2)).collect();
    let text = body(&format!("shape = {{ polygon = [{}] }}", points.join(", ")));
    check(&text, 3, 21, &["65 points", "at most 64"]);
}

#[test]
fn points_the_engine_welds_into_one_are_refused_at_the_polygon() {
    // three points 1e-5 apart: distinct to the 1e-6 check, one point to the engine
    check(
        &body("shape = { polygon = [[0, 0], [0.00001, 0], [0, 0.00001]] }"),
        3,
        21,
        &["body \"body0\"", "polygon"],
    );
}

#[test]
fn grid_position_beyond_f32_is_refused_at_the_spacing() {
    check(
        "name = \"t\"\n[[grid]]\nrows = 1\ncolumns = 3\nspacing = [3e38, 3e38]\nshape = { circle = 0.1 }\n",
        5,
        11,
        &["grid0", "body 2", "spacing"],
    );
}

#[test]
fn stack_offset_beyond_f32_is_refused_at_the_offset() {
    check(
        "name = \"t\"\n[[stack]]\ncount = 3\noffset = 3e38\n",
        4,
        10,
        &["stack0", "offset"],
    );
}

#[test]
fn chain_link_too_long_is_refused_at_the_link() {
    check(
        "name = \"t\"\n[[chain]]\nlinks = 4\nlink = [1e38, 0.1]\nanchor = [0, 0]\n",
        4,
        8,
        &["chain0", "body 3", "link"],
    );
    // one link: its position fits, but its edges' normals (and its inertia) do not
    check(
        "name = \"t\"\n[[chain]]\nlinks = 1\nlink = [3e38, 0.1]\nanchor = [0, 0]\njoint = \"distance\"\n",
        4,
        8,
        &["chain0_0", "does not fit f32"],
    );
}

#[test]
fn joint_length_at_creation_beyond_f32_is_refused_at_the_anchors() {
    check(
        "name = \"t\"\n[[body]]\nname = \"a\"\nshape = { circle = 1 }\nposition = [-3e38, 0]\n\
         [[body]]\nname = \"b\"\nshape = { circle = 1 }\nposition = [3e38, 0]\n\
         [[joint]]\ntype = \"distance\"\nbodies = [\"a\", \"b\"]\n",
        12,
        10,
        &["distance joint \"a\"-\"b\"", "length", "not finite"],
    );
}

#[test]
fn huge_box_has_no_finite_mass_and_is_refused_at_the_shape() {
    check(
        &body("shape = { box = [3e38, 3e38] }"),
        3,
        9,
        &["body \"body0\"", "does not fit f32", "too large"],
    );
}

#[test]
fn tiny_box_has_no_usable_mass_and_is_refused_at_the_shape() {
    check(
        &body("shape = { box = [1e-30, 1e-30] }"),
        3,
        9,
        &["body \"body0\"", "does not fit f32", "too small"],
    );
}

#[test]
fn huge_density_is_refused_at_the_density() {
    check(
        &body("shape = { box = [1e5, 1e5] }\ndensity = 1e30"),
        4,
        11,
        &["mass is inf"],
    );
}

#[test]
fn infinite_energy_is_refused_at_the_velocity_that_makes_it() {
    check(
        &body("shape = { circle = 1 }\nangular_velocity = 1e38"),
        4,
        20,
        &["kinetic energy is not finite"],
    );
    check(
        &body("shape = { circle = 1 }\nvelocity = [1e20, 0]"),
        4,
        12,
        &["kinetic energy is not finite"],
    );
    check(
        // a static pad 2e10 m below keeps the scene's origin (its centre) at 0, so the
        // ball's potential energy, measured from there, is m g 1e10
        "name = \"t\"\n[world]\ngravity = [0, -1e30]\n[[body]]\nshape = { circle = 1 }\nposition = [0, 1e10]\n[[body]]\ntype = \"static\"\nshape = { circle = 1 }\nposition = [0, -1e10]\n",
        6,
        12,
        &["potential energy is not finite"],
    );
}

#[test]
fn energy_and_mass_of_every_loaded_scene_are_finite() {
    // the largest values that still fit: accepted, and the world agrees
    let sc = load_str(
        &body("shape = { circle = 1 }\nangular_velocity = 1e18\nvelocity = [1e18, 0]"),
        "ok.toml",
    )
    .unwrap();
    let w = sandbox2d::World::from_def(&sc.world, sc.world.solver.resolve()).unwrap();
    assert!(w.energy().is_finite() && w.energy() > 1e36);
}

#[test]
fn names_in_messages_are_quoted_with_escapes() {
    // a newline, a carriage return and an escape sequence in a body name
    for (name, shown) in [
        ("a\\nb", "\"a\\nb\""),
        ("ok\\rerror: spoofed", "\"ok\\rerror: spoofed\""),
        ("\\u001b[2J", "\"\\u{1b}[2J\""),
    ] {
        let text =
            format!("name = \"t\"\n[[body]]\nname = \"{name}\"\nshape = {{ circle = -1 }}\n");
        let e = refuse(&text);
        let m = e.to_string();
        assert!(!m.chars().any(|c| c.is_control()), "{m:?}");
        assert!(
            m.contains(&format!("body {shown}")),
            "{m:?} should show {shown}"
        );
    }
    // a name in a joint that does not exist, a type and a colour
    let e = refuse("name = \"t\"\n[[force]]\nbody = \"x\\ny\"\nforce = [1, 0]\n");
    assert!(e.to_string().contains("no body named \"x\\ny\""), "{e}");
    let e = refuse(&body("shape = { circle = 1 }\ntype = \"st\\natic\""));
    assert!(e.to_string().contains("\"st\\natic\""), "{e}");
    let e = refuse(&body("shape = { circle = 1 }\ncolor = \"\\u001b\""));
    assert!(!e.to_string().chars().any(|c| c.is_control()), "{e}");
}

#[test]
fn the_body_limit_is_per_file() {
    // 20 stacks of 100,000 boxes: each table is under the limit, the file is not
    let mut text = String::from("name = \"t\"\n");
    for _ in 0..20 {
        text.push_str("[[stack]]\ncount = 100000\n");
    }
    let e = refuse(&text);
    // line 23: the count of the 11th table
    assert_eq!(e.line(), Some(23), "{e}");
    assert!(e.message().contains("stack10"), "{e}");
    assert!(e.message().contains("1100000 in the file"), "{e}");
    assert!(e.message().contains("at most 1000000 in one file"), "{e}");
}

#[test]
fn iterations_and_substeps_have_upper_bounds() {
    check(
        "name = \"t\"\n[solver]\niterations = 1000001\n",
        3,
        14,
        &[
            "iterations must be an integer from 1 to 10000",
            "got 1000001",
        ],
    );
    check(
        "name = \"t\"\n[solver]\nsubsteps = 1001\n",
        3,
        12,
        &["substeps must be an integer from 1 to 1000", "got 1001"],
    );
    check(
        "name = \"t\"\n[solver]\niterations = 1e9\n",
        3,
        14,
        &["expected u32"],
    );
    let sc = load_str(
        "name = \"t\"\n[solver]\niterations = 10000\nsubsteps = 1000\n",
        "ok.toml",
    )
    .unwrap();
    assert_eq!(sc.world.solver.iterations, Some(10000));
}

#[test]
fn friction_is_bounded_so_that_mixing_fits_f32() {
    // sqrt(a b) of two 1e20 frictions overflows: the solver would see NaN bounds
    check(
        &body("shape = { circle = 1 }\nfriction = 1e20"),
        4,
        12,
        &["friction must be at most 1e6"],
    );
    check(
        "name = \"t\"\n[[pyramid]]\nbase = 2\nfriction = 1e7\n",
        4,
        12,
        &["pyramid0", "friction"],
    );
    assert!(load_str(&body("shape = { circle = 1 }\nfriction = 1e6"), "ok.toml").is_ok());
}

#[test]
fn soft_step_is_the_old_spelling_of_kind_soft() {
    let kind = |text: &str| load_str(text, "k.toml").unwrap().world.solver.kind;
    assert_eq!(
        kind("name = \"t\"\n[solver]\nsoft_step = true\n"),
        Some(SolverKind::Soft)
    );
    assert_eq!(
        kind("name = \"t\"\n[solver]\nsoft_step = false\n"),
        Some(SolverKind::Pgs)
    );
    assert_eq!(
        kind("name = \"t\"\n[solver]\nkind = \"soft\"\n"),
        Some(SolverKind::Soft)
    );
    // no kind at all: the soft step is the default
    assert_eq!(kind("name = \"t\"\n"), None);
    assert_eq!(
        sandbox2d::SolverOverrides::default().resolve().kind,
        SolverKind::Soft
    );
    check(
        "name = \"t\"\n[solver]\nkind = \"pgs\"\nsoft_step = true\n",
        4,
        13,
        &["soft_step = true contradicts kind = \"pgs\""],
    );
}

#[test]
fn filter_mask_naming_an_unknown_category() {
    // line 4: filter = { mask = ["debris"] }; "debris" is at column 21
    check(
        &body("shape = { circle = 1.0 }\nfilter = { mask = [\"debris\"] }"),
        4,
        20,
        &["unknown category", "\"debris\"", "default"],
    );
}

#[test]
fn filter_group_out_of_range() {
    check(
        &body("shape = { circle = 1.0 }\nfilter = { group = 3000000000 }"),
        4,
        20,
        &["group", "3000000000"],
    );
}

#[test]
fn filter_unknown_key() {
    check(
        &body("shape = { circle = 1.0 }\nfilter = { categroy = \"a\" }"),
        4,
        12,
        &["unknown field", "categroy"],
    );
}

#[test]
fn more_than_32_filter_categories() {
    // "default" and 31 names fit; the 32nd name (the 33rd category) is refused where it
    // is written
    let mut text = String::from("name = \"t\"\n");
    for k in 0..32 {
        text.push_str(&format!(
            "[[body]]\nname = \"b{k}\"\nshape = {{ circle = 1.0 }}\nfilter = {{ category = \"c{k}\" }}\n"
        ));
    }
    // body k's filter line is 2 + 4 k + 3
    check(&text, 2 + 4 * 31 + 3, 23, &["c31", "at most 32"]);
}

/// A 2 x 2 grid table with the given extra lines (from line 7).
fn grid(lines: &str) -> String {
    format!(
        "name = \"t\"\n[[grid]]\nrows = 2\ncolumns = 2\nspacing = [1.0, 1.0]\nshape = {{ circle = 0.4 }}\n{lines}\n"
    )
}

#[test]
fn grid_static_cell_outside_the_grid() {
    // line 7: static_cells = [[0, 0], [2, 0]]; the second cell is at column 26
    check(
        &grid("static_cells = [[0, 0], [2, 0]]"),
        7,
        25,
        &["grid0", "static_cells", "[2, 0]", "outside the grid"],
    );
    check(
        &grid("static_cells = [[0, -1]]"),
        7,
        17,
        &["[0, -1]", "outside the grid"],
    );
}

#[test]
fn grid_joints_of_an_unknown_kind() {
    check(
        &grid("joints = \"weld\""),
        7,
        10,
        &["grid0", "joints", "\"weld\"", "hinge"],
    );
}

#[test]
fn generator_filter_naming_an_unknown_category() {
    check(
        "name = \"t\"\n[[stack]]\ncount = 2\nfilter = { mask = [\"debris\"] }\n",
        4,
        20,
        &["stack0", "unknown category", "\"debris\""],
    );
}

#[test]
fn generators_give_their_filter_to_every_body_they_make() {
    let text = "name = \"t\"\n\
        [[stack]]\ncount = 3\nfilter = { category = \"boxes\", group = -2 }\n\
        [[chain]]\nlinks = 3\nlink = [0.5, 0.1]\nanchor = [0.0, 9.0]\nend = { shape = { circle = 0.3 } }\nfilter = { group = -1 }\n\
        [[pyramid]]\nbase = 2\norigin = [10.0, 0.0]\nfilter = { category = \"boxes\" }\n";
    let scene = load_str(text, "ok.toml").unwrap();
    let bodies = &scene.world.bodies;
    let named = |prefix: &'static str| bodies.iter().filter(move |b| b.name.starts_with(prefix));
    // "boxes" is the second category (bit 1), after "default"
    for b in named("stack0") {
        assert_eq!(
            (b.filter.category, b.filter.group),
            (1 << 1, -2),
            "{}",
            b.name
        );
    }
    // the chain's anchor, links and end all take the filter
    assert_eq!(named("chain0").count(), 5);
    for b in named("chain0") {
        assert_eq!(b.filter.group, -1, "{}", b.name);
    }
    for b in named("pyramid0") {
        assert_eq!(b.filter.category, 1 << 1, "{}", b.name);
    }
}

#[test]
fn a_hinged_grid_joins_each_cell_to_its_left_and_lower_neighbours() {
    let text =
        grid("joints = \"hinge\"\nstatic_cells = [[1, 0]]\nrows = 3").replace("rows = 2\n", "");
    let scene = load_str(&text, "ok.toml").unwrap();
    let w = &scene.world;
    // 3 rows x 2 columns: 3 horizontal + 4 vertical hinges
    assert_eq!(w.joints.len(), 2 * 3 * 2 - 3 - 2);
    for j in &w.joints {
        let [a, b] = j.bodies.map(|i| w.bodies[i].position);
        // neighbours 1 m apart, the hinge at their midpoint
        assert!((a.distance(b) - 1.0).abs() < 1e-6);
        assert!((j.anchor.unwrap() - (a + b) / 2.0).length() < 1e-6);
    }
    let statics: Vec<&str> = w
        .bodies
        .iter()
        .filter(|b| b.body_type == sandbox2d::BodyType::Static)
        .map(|b| b.name.as_str())
        .collect();
    // row 1, column 0 is body 1 * 2 + 0
    assert_eq!(statics, ["grid0_2"]);
}

#[test]
fn capsule_no_longer_than_twice_its_radius() {
    check(
        &body("shape = { capsule = { length = 1.0, radius = 0.5 } }"),
        3,
        32,
        &["capsule length", "more than twice its radius", "got 1"],
    );
}

#[test]
fn capsule_with_a_zero_radius() {
    check(
        &body("shape = { capsule = { length = 1.0, radius = 0.0 } }"),
        3,
        46,
        &["capsule radius must be > 0"],
    );
}

#[test]
fn radius_on_a_circle() {
    check(
        &body("shape = { circle = 1.0, radius = 0.1 }"),
        3,
        34,
        &["`radius` rounds a box or a polygon", "circle"],
    );
}

#[test]
fn box_radius_of_half_its_side() {
    check(
        &body("shape = { box = [1.0, 0.4], radius = 0.2 }"),
        3,
        38,
        &["less than half its smaller side", "got 0.2"],
    );
}

#[test]
fn segment_on_a_dynamic_body() {
    check(
        &body("shape = { segment = [[0, 0], [1, 0]] }"),
        3,
        9,
        &["a segment has no area", "static or kinematic"],
    );
}

#[test]
fn segment_with_three_points() {
    check(
        &body("type = \"static\"\nshape = { segment = [[0, 0], [1, 0], [2, 0]] }"),
        4,
        21,
        &["segment needs exactly 2 points", "got 3"],
    );
}

#[test]
fn rounded_shapes_load() {
    let text = "name = \"t\"\n[[body]]\nshape = { capsule = { length = 1.0, radius = 0.2 } }\n\
                [[body]]\nname = \"b\"\nshape = { box = [1, 1], radius = 0.1 }\n\
                [[body]]\nname = \"p\"\nshape = { polygon = [[0, 0], [1, 0], [0, 1]], radius = 0.1 }\n\
                [[body]]\nname = \"s\"\ntype = \"static\"\nshape = { segment = [[0, 0], [1, 0]] }\n";
    let scene = load_str(text, "ok.toml").unwrap();
    let kinds: Vec<String> = scene
        .world
        .bodies
        .iter()
        .map(|b| {
            format!("{:?}", b.shape)
                .split(' ')
                .next()
                .unwrap()
                .to_owned()
        })
        .collect();
    assert_eq!(
        kinds,
        ["Capsule", "RoundedBox", "RoundedPolygon", "Segment"]
    );
}

#[test]
fn polyline_with_one_point() {
    check(
        "name = \"t\"\n[[polyline]]\npoints = [[0, 0]]\n",
        3,
        10,
        &["polyline0", "at least 2 points", "got 1"],
    );
}

#[test]
fn polyline_with_a_repeated_point() {
    check(
        "name = \"t\"\n[[polyline]]\npoints = [[0, 0], [1, 0], [1, 0]]\n",
        3,
        27,
        &["point 2", "at least 1e-4 m apart"],
    );
}

#[test]
fn dynamic_polyline() {
    check(
        "name = \"t\"\n[[polyline]]\npoints = [[0, 0], [1, 0]]\ntype = \"dynamic\"\n",
        4,
        8,
        &["no area", "static or kinematic"],
    );
}

#[test]
fn wheel_needs_a_spring() {
    check(
        &joint("type = \"wheel\"\nbodies = [\"a\", \"b\"]\naxis = [0, 1]"),
        9,
        8,
        &[
            "wheel joint \"a\"-\"b\"",
            "needs `spring = { hertz, damping_ratio }`",
        ],
    );
}

#[test]
fn wheel_spring_hertz_not_positive_and_damping_ratio_negative() {
    check(
        &joint(
            "type = \"wheel\"\nbodies = [\"a\", \"b\"]\nspring = { hertz = 0, damping_ratio = 0.5 }",
        ),
        11,
        20,
        &["wheel joint", "spring hertz must be > 0", "got 0"],
    );
    check(
        &joint(
            "type = \"wheel\"\nbodies = [\"a\", \"b\"]\nspring = { hertz = 2, damping_ratio = -1 }",
        ),
        11,
        39,
        &["wheel joint", "spring damping_ratio must be >= 0", "got -1"],
    );
    check(
        &joint("type = \"wheel\"\nbodies = [\"a\", \"b\"]\nspring = { hertz = 2 }"),
        11,
        10,
        &["damping_ratio"],
    );
}

#[test]
fn wheel_motor_takes_max_torque() {
    check(
        &joint(
            "type = \"wheel\"\nbodies = [\"a\", \"b\"]\nspring = { hertz = 2, damping_ratio = 0.7 }\nmotor = { speed = 1, max_force = 2 }",
        ),
        12,
        34,
        &["a wheel motor takes `max_torque`, not `max_force`"],
    );
}

#[test]
fn wheel_refuses_the_keys_it_does_not_take() {
    for (line, key) in [
        ("anchors = [[0, 0], [1, 0]]", "anchors"),
        ("length = 1", "length"),
        ("servo = { target = 1 }", "servo"),
        ("damping = { linear = 1 }", "damping"),
        ("offset = [1, 0]", "offset"),
        ("max_torque = 1", "max_torque"),
        ("ground_anchors = [[0, 0], [1, 0]]", "ground_anchors"),
        ("ratio = 2", "ratio"),
    ] {
        let col = line.find('=').unwrap() + 3;
        check(
            &joint(&format!(
                "type = \"wheel\"\nbodies = [\"a\", \"b\"]\nspring = {{ hertz = 2, damping_ratio = 0.7 }}\n{line}"
            )),
            12,
            col,
            &[&format!("`{key}` does not apply to a wheel joint")],
        );
    }
}

#[test]
fn motor_joint_needs_max_force_and_max_torque() {
    check(
        &joint("type = \"motor\"\nbodies = [\"a\", \"b\"]\nmax_torque = 1"),
        9,
        8,
        &["motor joint \"a\"-\"b\"", "needs `max_force`"],
    );
    check(
        &joint("type = \"motor\"\nbodies = [\"a\", \"b\"]\nmax_force = 1"),
        9,
        8,
        &["motor joint \"a\"-\"b\"", "needs `max_torque`"],
    );
    check(
        &joint("type = \"motor\"\nbodies = [\"a\", \"b\"]\nmax_force = -1\nmax_torque = 1"),
        11,
        13,
        &["max_force must be >= 0", "got -1"],
    );
}

#[test]
fn motor_joint_correction_outside_zero_one() {
    check(
        &joint(
            "type = \"motor\"\nbodies = [\"a\", \"b\"]\nmax_force = 1\nmax_torque = 1\ncorrection = 1.5",
        ),
        13,
        14,
        &["motor joint", "correction must be in [0, 1]", "got 1.5"],
    );
}

#[test]
fn motor_joint_refuses_the_keys_it_does_not_take() {
    for (line, key, hint) in [
        ("anchor = [0, 0]", "anchor", "takes `offset`"),
        ("anchors = [[0, 0], [1, 0]]", "anchors", "takes `offset`"),
        ("axis = [1, 0]", "axis", ""),
        ("limits = [0, 1]", "limits", ""),
        (
            "motor = { speed = 1, max_force = 2 }",
            "motor",
            "takes `max_force` and `max_torque`",
        ),
        ("servo = { target = 1 }", "servo", ""),
        ("compliance = 1e-3", "compliance", "bounded"),
        ("spring = { hertz = 1, damping_ratio = 0 }", "spring", ""),
        ("ratio = 2", "ratio", ""),
    ] {
        let col = line.find('=').unwrap() + 3;
        check(
            &joint(&format!(
                "type = \"motor\"\nbodies = [\"a\", \"b\"]\nmax_force = 1\nmax_torque = 1\n{line}"
            )),
            13,
            col,
            &[&format!("`{key}` does not apply to a motor joint"), hint],
        );
    }
}

#[test]
fn pulley_needs_ground_anchors() {
    check(
        &joint("type = \"pulley\"\nbodies = [\"a\", \"b\"]"),
        9,
        8,
        &["pulley joint \"a\"-\"b\"", "needs `ground_anchors"],
    );
}

#[test]
fn pulley_ratio_not_positive() {
    for (v, got) in [("0", "got 0"), ("-2", "got -2")] {
        check(
            &joint(&format!(
                "type = \"pulley\"\nbodies = [\"a\", \"b\"]\nground_anchors = [[0, 5], [1, 5]]\nratio = {v}"
            )),
            12,
            9,
            &["pulley joint", "ratio must be > 0", got],
        );
    }
}

#[test]
fn pulley_refuses_the_keys_it_does_not_take() {
    for (line, key) in [
        ("anchor = [0, 0]", "anchor"),
        ("length = 3", "length"),
        ("axis = [1, 0]", "axis"),
        ("limits = [0, 1]", "limits"),
        ("compliance = 1e-3", "compliance"),
        ("motor = { speed = 1, max_force = 2 }", "motor"),
        ("damping = { linear = 1 }", "damping"),
        ("offset = [1, 0]", "offset"),
        ("max_force = 1", "max_force"),
    ] {
        let col = line.find('=').unwrap() + 3;
        check(
            &joint(&format!(
                "type = \"pulley\"\nbodies = [\"a\", \"b\"]\nground_anchors = [[0, 5], [1, 5]]\n{line}"
            )),
            12,
            col,
            &[&format!("`{key}` does not apply to a pulley joint")],
        );
    }
}

#[test]
fn older_joints_refuse_the_new_keys() {
    for (ty, line, key) in [
        (
            "weld",
            "spring = { hertz = 1, damping_ratio = 0 }",
            "spring",
        ),
        ("prismatic", "max_force = 1", "max_force"),
        (
            "distance",
            "ground_anchors = [[0, 5], [1, 5]]",
            "ground_anchors",
        ),
        ("weld", "angle = 1", "angle"),
        ("rope", "ratio = 2", "ratio"),
    ] {
        let col = line.find('=').unwrap() + 3;
        check(
            &joint(
                &format!("type = \"{ty}\"\nbodies = [\"a\", \"b\"]\nlength = 1\n{line}").replace(
                    "length = 1\n",
                    if ty == "rope" { "length = 1\n" } else { "" },
                ),
            ),
            if ty == "rope" { 12 } else { 11 },
            col,
            &[&format!("`{key}` does not apply to a {ty} joint")],
        );
    }
}

// compound bodies: `shapes = [...]`

#[test]
fn shape_and_shapes_together_are_refused_at_shapes() {
    check(
        &body("shape = { circle = 1 }\nshapes = [{ circle = 1 }]"),
        4,
        10,
        &["`shape`", "`shapes`", "not both"],
    );
}

#[test]
fn an_empty_shapes_list_is_refused() {
    check(&body("shapes = []"), 3, 10, &["1 to 64 parts", "got 0"]);
}

#[test]
fn a_segment_part_is_refused() {
    check(
        &body("shapes = [{ box = [1, 1] }, { segment = [[0, 0], [1, 0]] }]"),
        3,
        41,
        &["part 2", "segment", "capsule"],
    );
}

#[test]
fn a_moving_body_of_massless_sensor_parts_only_is_refused() {
    check(
        &body("shapes = [{ box = [1, 1], sensor = true, density = 0 }]"),
        3,
        10,
        &["every part is a massless sensor", "a part with mass"],
    );
}

#[test]
fn a_part_with_two_shapes_is_refused_at_the_part() {
    check(
        &body("shapes = [{ box = [1, 1] }, { circle = 1, box = [1, 1] }]"),
        3,
        29,
        &["part 2", "box and circle", "exactly one"],
    );
}

#[test]
fn a_part_density_of_zero_is_refused() {
    check(
        &body("shapes = [{ box = [1, 1], density = 0 }]"),
        3,
        37,
        &[
            "part 1",
            "density must be > 0 (or 0 on a sensor part)",
            "got 0",
        ],
    );
}

#[test]
fn a_part_filter_naming_an_unknown_category_is_refused() {
    check(
        &body("shapes = [{ box = [1, 1], filter = { mask = [\"nowhere\"] } }]"),
        3,
        46,
        &["part 1", "unknown category", "nowhere"],
    );
}

#[test]
fn a_particle_compound_is_refused() {
    check(
        &body("model = \"particle\"\nshapes = [{ circle = 1 }]"),
        4,
        10,
        &["particle", "circle shape", "compound"],
    );
}

#[test]
fn a_part_filter_category_counts_as_a_scene_category() {
    // the category named only by a part is known to the other body's mask
    let text = "name = \"t\"\n[[body]]\nname = \"a\"\nshapes = [{ circle = 1, filter = { category = \"spikes\" } }]\n[[body]]\nname = \"b\"\nshape = { circle = 1 }\nposition = [5, 0]\nfilter = { mask = [\"spikes\"] }\n";
    let scene = load_str(text, "ok.toml").unwrap_or_else(|e| panic!("{e}"));
    let b = &scene.world.bodies[1];
    assert_eq!(b.filter.mask, 1 << 1, "spikes is the second category");
}

/// Shapes the format accepts in range but whose derived numbers do not fit f32 (an
/// edge normal of a box thinner than f32 resolves, a segment longer than f32 holds)
/// are refused at the shape: a world holding one could not be saved and read back.
#[test]
fn shapes_that_do_not_fit_f32_are_refused_at_the_shape() {
    for (shape, what) in [
        ("{ box = [1e-45, 1.0] }", "box 1e-45 m wide"),
        ("{ capsule = [1e-30, 1e-31] }", "capsule 1e-30 m long"),
        (
            "{ segment = [[-3e38, 0], [3e38, 0]] }",
            "segment across f32",
        ),
    ] {
        let text = format!("name = \"t\"\n[[body]]\ntype = \"static\"\nshape = {shape}\n");
        let e = refuse(&text);
        assert_eq!((e.line(), e.column()), (Some(4), Some(9)), "{what}: {e}");
        assert!(e.message().contains("does not fit f32"), "{what}: {e}");
    }
    // the smallest and largest bodies the renderer is checked with still load
    for shape in [
        "{ box = [1e-6, 1e-6] }",
        "{ box = [1e9, 1e9] }",
        "{ circle = 1e-6 }",
    ] {
        let text = format!("name = \"t\"\n[[body]]\ntype = \"static\"\nshape = {shape}\n");
        load_str(&text, "ok.toml").unwrap_or_else(|e| panic!("{shape}: {e}"));
    }
}

/// A grid of circles far larger than its spacing overlaps in 50 million pairs, tens of
/// gigabytes once stepped: refused when it loads, at a body of the grid; filtered apart,
/// the same grid loads.
#[test]
fn bodies_overlapping_by_the_million_are_refused_when_they_load() {
    let grid = |filter: &str| {
        format!(
            "name = \"t\"\n[world]\ngravity = [0, -10]\n[[grid]]\nrows = 100\ncolumns = 100\nspacing = [1.0, 1.0]\nshape = {{ circle = 1000.0 }}\n{filter}"
        )
    };
    let e = refuse(&grid(""));
    assert_eq!((e.line(), e.column()), (Some(4), Some(1)), "{e}");
    assert!(
        e.message().contains("overlap in more than 1048576 pairs"),
        "{e}"
    );
    let sc = load_str(&grid("filter = { group = -1 }\n"), "ok.toml").unwrap();
    assert_eq!(sc.world.bodies.len(), 10_000);
    // the limit grows with the bodies: 8 a body
    assert_eq!(sandbox2d::world::max_start_pairs(10), 1 << 20);
    assert_eq!(sandbox2d::world::max_start_pairs(1_000_000), 8_000_000);
}

/// A scene file past 16 MiB is refused at the line and column where the limit falls,
/// before it is read whole; an endless one too.
#[test]
fn a_scene_file_past_the_size_limit_is_refused_before_it_is_read_whole() {
    let dir = std::env::temp_dir().join(format!("sandbox2d-big-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("big.toml");
    let line = "[[body]]\nshape = { circle = 1 }\n"; // 33 bytes, 2 lines
    let n = (sandbox2d::scene::MAX_FILE_BYTES as usize) / line.len() + 1;
    std::fs::write(&path, format!("name = \"big\"\n{}", line.repeat(n))).unwrap();
    let e = sandbox2d::scene::load_file(&path).unwrap_err();
    // the byte at the limit: past the 13-byte first line, in body table k
    let k = (sandbox2d::scene::MAX_FILE_BYTES as usize - 13) / line.len();
    let within = (sandbox2d::scene::MAX_FILE_BYTES as usize - 13) % line.len();
    let (l, c) = if within < 9 {
        (2 + 2 * k, within + 1)
    } else {
        (3 + 2 * k, within - 9 + 1)
    };
    assert_eq!((e.line(), e.column()), (Some(l), Some(c)), "{e}");
    assert!(e.message().contains("past 16 MiB"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
    if std::path::Path::new("/dev/zero").exists() {
        let e = sandbox2d::scene::load_file(std::path::Path::new("/dev/zero")).unwrap_err();
        assert!(e.message().contains("past 16 MiB"), "{e}");
    }
}

/// The byte ranges of the numbers in a scene's text (outside comments and strings).
fn numbers_in(text: &str) -> Vec<std::ops::Range<usize>> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let (mut i, mut in_comment, mut in_string) = (0, false, false);
    while i < b.len() {
        let c = b[i];
        if c == b'\n' {
            in_comment = false;
        }
        if in_comment {
            i += 1;
            continue;
        }
        if c == b'#' && !in_string {
            in_comment = true;
        } else if c == b'"' {
            in_string = !in_string;
        } else if !in_string
            && (c.is_ascii_digit() || c == b'-')
            && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_'))
        {
            let start = i;
            i += 1;
            while i < b.len()
                && (b[i].is_ascii_alphanumeric() || matches!(b[i], b'.' | b'-' | b'+'))
            {
                i += 1;
            }
            if b[start..i].iter().any(u8::is_ascii_digit) {
                out.push(start..i);
            }
            continue;
        }
        i += 1;
    }
    out
}

/// Every number of every built-in scene, set in turn to NaN, to 1e39 (past f32) and to
/// a string: each is refused, and the error's line and column are those of the value
/// itself (not of its array, its table, another body or the camera).
#[test]
fn every_number_of_every_builtin_scene_is_refused_at_itself() {
    let dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/scenes");
    let mut checked = 0;
    for name in sandbox2d::scene::builtin_names() {
        let text = std::fs::read_to_string(dir.join(format!("{name}.toml"))).unwrap();
        for r in numbers_in(&text) {
            let line = text[..r.start].matches('\n').count() + 1;
            let col = text[..r.start].rsplit('\n').next().unwrap().chars().count() + 1;
            for v in ["nan", "1e39", "\"x\""] {
                let mut t = text.clone();
                t.replace_range(r.clone(), v);
                let e = match load_str(&t, "s.toml") {
                    Ok(_) => panic!("{name}:{line}:{col}: {v} accepted"),
                    Err(e) => e,
                };
                assert_eq!(
                    (e.line(), e.column()),
                    (Some(line), Some(col)),
                    "{name}: {v} at {line}:{col}: {e}"
                );
                checked += 1;
            }
        }
    }
    // every built-in scene has numbers: some thousands of cases
    assert!(checked > 3000, "{checked}");
}

/// A camera size past the largest frame is refused where the scene gives it, not later
/// by the renderer without a place.
#[test]
fn a_camera_size_past_the_largest_frame_is_refused_at_the_side() {
    check(
        "name = \"t\"\n[camera]\nsize = [16385, 16]\n",
        3,
        9,
        &["camera", "size", "1..=16384", "16385"],
    );
    check(
        "name = \"t\"\n[camera]\nsize = [640, 0]\n",
        3,
        14,
        &["camera", "size", "[640, 0]"],
    );
    load_str("name = \"t\"\n[camera]\nsize = [16384, 1]\n", "ok.toml").unwrap();
}

/// A dotted key deeper than the TOML reader goes (it gives no place of its own) is
/// refused at the part that goes past the limit, not at 1:1.
#[test]
fn a_key_too_deep_for_the_reader_is_refused_where_it_goes_past() {
    let key = vec!["a"; 1000].join(".");
    check(
        &format!("name = \"t\"\n{key} = 1\n"),
        2,
        161,
        &["more than 80 levels"],
    );
    let key = vec!["b"; 81].join(" . ");
    check(
        &format!("name = \"t\"\n[t]\n\"x\" = 1\n{key} = 2\n"),
        4,
        1 + 80 * 4,
        &["more than 80 levels"],
    );
    // 80 parts are within the reader's depth (and refused as an unknown key)
    let key = vec!["c"; 80].join(".");
    check(
        &format!("name = \"t\"\n{key} = 1\n"),
        2,
        1,
        &["unknown field"],
    );
}

// ---- bodies that start asleep, damping, sleep thresholds, paths

#[test]
fn a_static_body_cannot_start_asleep() {
    check(
        &body("type = \"static\"\nshape = { circle = 1 }\nawake = false"),
        5,
        9,
        &["only a dynamic body can start asleep"],
    );
}

#[test]
fn a_body_that_starts_asleep_has_no_velocity() {
    check(
        &body("shape = { circle = 1 }\nvelocity = [1, 0]\nawake = false"),
        5,
        9,
        &["starts asleep", "no velocity"],
    );
}

#[test]
fn a_grid_of_kinematic_bodies_cannot_start_asleep() {
    check(
        "name = \"t\"\n[[grid]]\nrows = 1\ncolumns = 1\nspacing = [1, 1]\ntype = \"kinematic\"\nshape = { circle = 1 }\nawake = false\n",
        8,
        9,
        &["grid0", "only a dynamic body can start asleep"],
    );
}

#[test]
fn negative_damping_is_refused() {
    check(
        &body("shape = { circle = 1 }\nlinear_damping = -0.1"),
        4,
        18,
        &["linear_damping", ">= 0", "-0.1"],
    );
}

#[test]
fn damping_on_a_static_body_is_refused() {
    check(
        &body("type = \"static\"\nshape = { circle = 1 }\nangular_damping = 1"),
        5,
        19,
        &["angular_damping", "dynamic body only"],
    );
}

#[test]
fn a_negative_sleep_threshold_is_refused() {
    check(
        &body("shape = { circle = 1 }\nsleep_threshold = -1"),
        4,
        19,
        &["sleep_threshold", ">= 0"],
    );
}

#[test]
fn only_a_kinematic_body_oscillates() {
    check(
        &body("shape = { circle = 1 }\noscillate = { amplitude = [1, 0], angular_frequency = 1 }"),
        4,
        13,
        &["only a kinematic body follows a path", "oscillate"],
    );
}

#[test]
fn an_oscillation_needs_a_positive_angular_frequency() {
    check(
        &body(
            "type = \"kinematic\"\nshape = { circle = 1 }\noscillate = { amplitude = [1, 0], angular_frequency = 0 }",
        ),
        5,
        55,
        &["angular_frequency", "> 0", "got 0"],
    );
}

#[test]
fn an_unknown_key_in_oscillate_is_refused() {
    check(
        &body(
            "type = \"kinematic\"\nshape = { circle = 1 }\noscillate = { amplitude = [1, 0], omega = 1 }",
        ),
        5,
        35,
        &["unknown field", "omega"],
    );
}

// ---- loops

#[test]
fn a_loop_needs_three_points() {
    check(
        "name = \"t\"\n[[polyline]]\npoints = [[0, 0], [1, 0]]\nloop = true\n",
        4,
        8,
        &["polyline0", "a loop needs at least 3 points", "got 2"],
    );
}

#[test]
fn a_loop_does_not_repeat_its_first_point() {
    check(
        "name = \"t\"\n[[polyline]]\npoints = [[0, 0], [1, 0], [1, 1], [0, 0]]\nloop = true\n",
        4,
        8,
        &["polyline0", "must not repeat the first"],
    );
}

#[test]
fn a_closed_loop_makes_one_segment_per_point_each_knowing_both_neighbours() {
    let text =
        "name = \"t\"\n[[polyline]]\npoints = [[0, 0], [2, 0], [2, 2], [0, 2]]\nloop = true\n";
    let sc = load_str(text, "ok.toml").unwrap_or_else(|e| panic!("{e}"));
    let segs: Vec<_> = sc.world.bodies.iter().map(|b| b.shape.clone()).collect();
    assert_eq!(segs.len(), 4, "4 points close into 4 segments");
    for s in segs {
        match s {
            sandbox2d::ShapeDef::ChainSegment { prev, next, .. } => {
                assert!(prev.is_some() && next.is_some(), "a loop has no open end")
            }
            other => panic!("{other:?}"),
        }
    }
}

// ---- hinge springs and reference angles

fn two_bodies(joint: &str) -> String {
    format!(
        "name = \"t\"\n[[body]]\nname = \"a\"\nshape = {{ circle = 1 }}\n[[body]]\nname = \"b\"\nshape = {{ circle = 1 }}\nposition = [3, 0]\n[[joint]]\n{joint}\n"
    )
}

#[test]
fn a_hinge_takes_a_servo_or_a_spring_not_both() {
    check(
        &two_bodies(
            "type = \"hinge\"\nbodies = [\"a\", \"b\"]\nservo = { target = 0 }\nspring = { hertz = 5, damping_ratio = 0.5 }",
        ),
        13,
        10,
        &["servo", "spring", "not both"],
    );
}

#[test]
fn a_hinge_spring_needs_positive_hertz() {
    check(
        &two_bodies(
            "type = \"hinge\"\nbodies = [\"a\", \"b\"]\nspring = { hertz = 0, damping_ratio = 0.5 }",
        ),
        12,
        20,
        &["spring hertz", "> 0"],
    );
}

#[test]
fn a_reference_angle_is_for_hinges() {
    check(
        &two_bodies("type = \"weld\"\nbodies = [\"a\", \"b\"]\nreference_angle = 0.5"),
        12,
        19,
        &["`reference_angle` does not apply to a weld joint"],
    );
}

#[test]
fn a_spring_still_does_not_apply_to_a_prismatic_joint() {
    check(
        &two_bodies(
            "type = \"prismatic\"\nbodies = [\"a\", \"b\"]\nspring = { hertz = 5, damping_ratio = 0.5 }",
        ),
        12,
        10,
        &["`spring` does not apply to a prismatic joint"],
    );
}

// ---- humans

#[test]
fn humans_count_of_zero_is_refused() {
    check(
        "name = \"t\"\n[[humans]]\ncount = 0\n",
        3,
        9,
        &["humans0", "count must be >= 1"],
    );
}

#[test]
fn humans_scale_must_be_positive() {
    check(
        "name = \"t\"\n[[humans]]\nscale = -1\n",
        3,
        9,
        &["humans0", "scale", "> 0"],
    );
}

#[test]
fn humans_group_must_be_positive() {
    check(
        "name = \"t\"\n[[humans]]\ngroup = 0\n",
        3,
        9,
        &["humans0", "group must be an integer from 1"],
    );
}

#[test]
fn humans_negative_joint_hertz_is_refused() {
    check(
        "name = \"t\"\n[[humans]]\njoint_hertz = -5\n",
        3,
        15,
        &["humans0", "joint_hertz", ">= 0"],
    );
}

#[test]
fn an_unknown_key_in_humans_is_refused() {
    check(
        "name = \"t\"\n[[humans]]\nheight = 2\n",
        3,
        1,
        &["unknown field", "height"],
    );
}

#[test]
fn a_human_has_eleven_bones_on_ten_hinges_in_the_human_category() {
    let text = "name = \"t\"\n[[humans]]\ncount = 2\ngroup = 3\n";
    let sc = load_str(text, "ok.toml").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(sc.world.bodies.len(), 22);
    assert_eq!(sc.world.joints.len(), 20);
    // "human" is the scene's second category (bit 1), after "default"
    let hip = &sc.world.bodies[0];
    assert_eq!(hip.name, "humans0_0_hip");
    assert_eq!((hip.filter.category, hip.filter.mask), (2, 3));
    assert_eq!(hip.filter.group, -3);
    assert_eq!(
        sc.world.bodies[11].filter.group, -4,
        "the next human's group"
    );
    for j in &sc.world.joints {
        let [lo, hi] = j.limits.expect("every hinge has limits");
        assert!(lo < hi);
        assert!(j.spring.is_some() && j.motor.is_some());
    }
}

// ---- grids of compounds and of several shapes

#[test]
fn a_grid_takes_one_of_shape_shapes_and_shape_cycle() {
    check(
        "name = \"t\"\n[[grid]]\nrows = 1\ncolumns = 1\nspacing = [1, 1]\nshape = { circle = 1 }\nshape_cycle = [{ circle = 1 }]\n",
        7,
        15,
        &["grid0", "one of `shape`, `shapes` and `shape_cycle`"],
    );
}

#[test]
fn a_grid_without_a_shape_is_refused() {
    check(
        "name = \"t\"\n[[grid]]\nrows = 1\ncolumns = 1\nspacing = [1, 1]\n",
        2,
        1,
        &["grid0", "missing field `shape`"],
    );
}

#[test]
fn a_grid_count_beyond_its_cells_is_refused() {
    check(
        "name = \"t\"\n[[grid]]\nrows = 2\ncolumns = 2\ncount = 5\nspacing = [1, 1]\nshape = { circle = 0.1 }\n",
        5,
        9,
        &["grid0", "count must be at most rows x columns = 4", "got 5"],
    );
}

#[test]
fn an_empty_shape_cycle_is_refused() {
    check(
        "name = \"t\"\n[[grid]]\nrows = 1\ncolumns = 1\nspacing = [1, 1]\nshape_cycle = []\n",
        6,
        15,
        &["grid0", "shape_cycle needs at least one shape"],
    );
}

#[test]
fn a_grid_cycles_its_shapes_and_stops_at_its_count() {
    let text = "name = \"t\"\n[[grid]]\nrows = 2\ncolumns = 3\ncount = 5\nspacing = [1, 1]\nshape_cycle = [{ circle = 0.1 }, { box = [0.2, 0.2] }]\n";
    let sc = load_str(text, "ok.toml").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(sc.world.bodies.len(), 5);
    for (i, b) in sc.world.bodies.iter().enumerate() {
        let circle = matches!(b.shape, sandbox2d::ShapeDef::Circle { .. });
        assert_eq!(circle, i % 2 == 0, "body {i}");
    }
}

#[test]
fn a_compound_of_more_than_64_parts_is_refused() {
    let parts = vec!["{ circle = 0.1 }"; 65].join(", ");
    check(
        &body(&format!("shapes = [{parts}]")),
        3,
        10,
        &["`shapes` takes 1 to 64 parts, got 65"],
    );
}

// ---- spawns

#[test]
fn spawn_every_zero_is_refused() {
    check(
        "name = \"t\"\n[[spawn]]\nevery = 0\n[[spawn.body]]\nshape = { circle = 1 }\n",
        3,
        9,
        &["spawn0", "every must be >= 1"],
    );
}

#[test]
fn spawn_keep_zero_is_refused() {
    check(
        "name = \"t\"\n[[spawn]]\nevery = 4\nkeep = 0\n[[spawn.body]]\nshape = { circle = 1 }\n",
        4,
        8,
        &["spawn0", "keep must be >= 1"],
    );
}

#[test]
fn a_spawn_that_makes_nothing_is_refused() {
    check(
        "name = \"t\"\n[[spawn]]\nevery = 4\n",
        2,
        1,
        &["spawn0", "makes no body"],
    );
}

#[test]
fn an_unknown_key_in_a_spawn_is_refused() {
    check(
        "name = \"t\"\n[[spawn]]\nevry = 4\n",
        3,
        1,
        &["unknown field", "evry"],
    );
}

#[test]
fn a_spawned_body_is_checked_like_any_body() {
    check(
        "name = \"t\"\n[[spawn]]\nevery = 4\n[[spawn.body]]\nshape = { circle = -1 }\n",
        5,
        20,
        &["body \"body0\"", "radius", "> 0"],
    );
}

#[test]
fn a_spawned_joint_names_only_the_group_s_bodies() {
    let text = "name = \"t\"\n[[body]]\nname = \"ground\"\ntype = \"static\"\nshape = { box = [4, 1] }\n\
                [[spawn]]\nevery = 4\n[[spawn.body]]\nname = \"ball\"\nshape = { circle = 1 }\n\
                [[spawn.joint]]\ntype = \"hinge\"\nbodies = [\"ground\", \"ball\"]\n";
    check(text, 13, 11, &["no body named \"ground\""]);
}

#[test]
fn a_spawned_body_cannot_oscillate() {
    check(
        "name = \"t\"\n[[spawn]]\nevery = 4\n[[spawn.body]]\ntype = \"kinematic\"\nshape = { circle = 1 }\noscillate = { amplitude = [1, 0], angular_frequency = 1 }\n",
        7,
        13,
        &["spawn0", "cannot follow a path"],
    );
}

#[test]
fn a_scene_with_spawns_keeps_hashes_out_of_its_body_names() {
    check(
        "name = \"t\"\n[[body]]\nname = \"a#1\"\nshape = { circle = 1 }\n[[spawn]]\nevery = 4\n[[spawn.body]]\nshape = { circle = 1 }\n",
        3,
        8,
        &["\"a#1\"", "cannot hold a '#'"],
    );
}

#[test]
fn a_spawn_table_becomes_its_timing_and_its_group() {
    let text = "name = \"t\"\n[[spawn]]\nevery = 8\nfirst = 2\ncount = 10\nkeep = 3\ncycle = 4\noffset = [2, 0]\n\
                [[spawn.humans]]\norigin = [0, 5]\n";
    let sc = load_str(text, "ok.toml").unwrap_or_else(|e| panic!("{e}"));
    let s = &sc.world.spawns[0];
    assert_eq!(
        (s.every, s.first, s.count, s.keep, s.cycle),
        (8, 2, Some(10), Some(3), Some(4))
    );
    assert_eq!((s.bodies.len(), s.joints.len()), (11, 10));
    assert_eq!(s.bodies[0].name, "spawn0/humans0_0_hip");
    assert!(
        sc.world.bodies.is_empty(),
        "nothing is made before the first step"
    );
    assert_eq!(s.due(2), Some(0));
    assert_eq!(s.due(9), None);
    assert_eq!(s.due(10), Some(1));
    assert_eq!(s.due(2 + 8 * 10), None, "ten copies in all");
    assert_eq!(
        s.offset_of(5),
        glam::Vec2::new(2.0, 0.0),
        "the offsets cycle every 4"
    );
}

mod common;

#[test]
fn the_cli_refuses_a_bad_spawn_table_with_one_line_and_exit_2() {
    // as a user meets it: `simulate` on the file, file:line:col, nothing run
    let path = common::cli::tmp("bad_spawn.toml");
    std::fs::write(
        &path,
        "name = \"t\"\n[[spawn]]\nevery = 8\nkeep = 0\n[[spawn.humans]]\ncount = 5\n",
    )
    .unwrap();
    let out = common::cli::sandbox2d()
        .args(["simulate", path.to_str().unwrap(), "--steps", "10"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(out.stdout.is_empty(), "nothing was run");
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("bad_spawn.toml:4:8: spawn0: keep must be >= 1, got 0"),
        "{err}"
    );
}
