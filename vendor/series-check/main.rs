//! A stepping check of the rapier patch series, without pbd (which builds only on the whole
//! series): a fixed base, a four-joint arm (motors, one limit) with two two-joint fingers (limits,
//! motors, one finger's joints coupled), a ball on the ground, 3000 steps at rapier's default `dt`
//! with the arm's motor targets changed every 5 steps for half of each second. Prints every body's
//! final position and velocity in full precision, so two builds can be compared byte for byte.
//! Run by `run.sh` against each state of the series.
use rapier3d_f64::prelude::*;
use rapier3d_f64::math::Vector;

fn main() {
    let mut w = PhysicsWorld::new();
    w.gravity = Vector::new(0.0, 0.0, -9.81);
    set_flags(&mut w.integration_parameters);
    let ground = w.insert_body(RigidBodyBuilder::fixed());
    w.insert_collider(ColliderBuilder::cuboid(5.0, 5.0, 0.1).translation(Vector::new(0.0, 0.0, -0.1)), Some(ground));
    let ball = w.insert_body(RigidBodyBuilder::dynamic().can_sleep(false).translation(Vector::new(0.45, 0.05, 0.08)));
    w.insert_collider(ColliderBuilder::ball(0.08).density(500.0), Some(ball));

    let base = w.insert_body(RigidBodyBuilder::fixed().translation(Vector::new(0.0, 0.0, 0.25)));
    let mut bodies = vec![];
    let mut joints = vec![];
    let axes = [Vector::Z, Vector::Y, Vector::X, Vector::Y];
    let mut parent = base;
    for (k, ax) in axes.iter().enumerate() {
        let b = w.insert_body(RigidBodyBuilder::dynamic().can_sleep(false).translation(Vector::new(0.12 * (k as f64 + 1.0), 0.0, 0.5)));
        w.insert_collider(ColliderBuilder::cuboid(0.05, 0.02, 0.02).density(800.0), Some(b));
        let mut j = RevoluteJointBuilder::new(*ax)
            .local_anchor1(Vector::new(if k == 0 { 0.0 } else { 0.06 }, 0.0, 0.0))
            .local_anchor2(Vector::new(-0.06, 0.0, 0.0))
            .motor_position(0.0, 200.0, 20.0)
            .motor_max_force(50.0)
            .contacts_enabled(false);
        if k == 1 { j = j.limits([-0.3, 0.3]); }
        let h = w.insert_multibody_joint(parent, b, j).unwrap();
        bodies.push(b);
        joints.push(h);
        parent = b;
    }
    let wrist = parent;
    for side in [-1.0, 1.0] {
        let mut p = wrist;
        for k in 0..2 {
            let b = w.insert_body(RigidBodyBuilder::dynamic().can_sleep(false).translation(Vector::new(0.55 + 0.05 * k as f64, 0.03 * side, 0.5)));
            w.insert_collider(ColliderBuilder::cuboid(0.025, 0.008, 0.008).density(800.0), Some(b));
            let j = RevoluteJointBuilder::new(Vector::Z)
                .local_anchor1(Vector::new(if k == 0 { 0.06 } else { 0.025 }, if k == 0 { 0.03 * side } else { 0.0 }, 0.0))
                .local_anchor2(Vector::new(-0.025, 0.0, 0.0))
                .limits([-0.1, 1.0])
                .motor_position(0.2, 5.0, 0.5)
                .motor_max_force(2.0)
                .contacts_enabled(false);
            let h = w.insert_multibody_joint(p, b, j).unwrap();
            bodies.push(b);
            joints.push(h);
            p = b;
        }
    }
    // Couple the two joints of the first finger (q2 = 0.7 q1).
    {
        let (_, l1) = w.multibody_joints.get(joints[4]).unwrap();
        let (mb, l2) = w.multibody_joints.get_mut(joints[5]).unwrap();
        mb.add_dof_coupling(MultibodyDofCoupling { link1: l1, dof1: 0, axis1: 3, link2: l2, dof2: 0, axis2: 3, coeff: 0.7, offset: 0.0 });
    }
    let targets = [[0.0, -0.25, 0.2, 0.4], [0.6, 0.25, -0.2, -0.3]];
    for step in 0..3000 {
        if step % 5 == 0 && (step / 500) % 2 == 0 {
            let t = targets[(step / 1000) % 2];
            for (k, h) in joints.iter().take(4).enumerate() {
                let (mb, l) = w.multibody_joints.get_mut(*h).unwrap();
                mb.link_mut(l).unwrap().joint.data.set_motor_position(JointAxis::AngX, t[k], 200.0, 20.0);
            }
        }
        w.step();
    }
    let mut sum = [0.0f64; 4];
    for b in bodies.iter().chain([ball].iter()) {
        let rb = &w.bodies[*b];
        let p = rb.position().translation;
        let v = rb.linvel();
        sum[0] += p.x + p.y + p.z;
        sum[1] += v.x + v.y + v.z;
        sum[2] += rb.angvel().x + rb.angvel().y + rb.angvel().z;
        println!("{:?} {:?}", p, v);
    }
    let bp = w.bodies[ball].position().translation;
    println!("ball {:?}", bp);
    println!("sums {:?}", sum);
}

/// Sets the opt-in fields of the series that exist at this state (written by `run.sh`).
#[allow(unused_variables)]
fn set_flags(ip: &mut IntegrationParameters) {
    include!(concat!(env!("CARGO_MANIFEST_DIR"), "/flags.rs"))
}
