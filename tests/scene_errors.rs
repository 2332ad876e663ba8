//! Every refusal of the scene format, one by one: the exact line and column, and a
//! message that names what is wrong.

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
        11,
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
        17,
        &["box", "size", "> 0", "[0, 1]"],
    );
}

#[test]
fn box_size_is_refused_on_static_bodies_too() {
    check(
        &body("type = \"static\"\nshape = { box = [4.0, -1.0] }"),
        4,
        17,
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
        30,
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
        &["solver", "dt", "> 0", "got 0"],
    );
}

#[test]
fn iterations_zero() {
    check(
        "name = \"t\"\n[solver]\niterations = 0\n",
        3,
        14,
        &["iterations", ">= 1", "got 0"],
    );
}

#[test]
fn substeps_zero() {
    check(
        "name = \"t\"\n[solver]\nkind = \"xpbd\"\nsubsteps = 0\n",
        4,
        12,
        &["substeps", ">= 1"],
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
    check(
        "name = \"t\"\n[camera]\nsize = [1280, 0]\n",
        3,
        8,
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
