//! The robot side runs Pick-And-Place with ψ on hardware that is not the simulator: the kinematic
//! plant with scripted sensors of `examples/kinematic_pick.rs` (the example itself, run as a test).

use crate::example;

#[test]
fn pick_and_place_runs_on_a_kinematic_plant_with_scripted_sensors() {
    let (reached, inside) = example::run().expect("the example runs");
    assert!(reached, "the executive reached the schema's goal");
    assert!(inside, "the box ended inside bin-right");
}
