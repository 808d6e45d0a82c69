//! Grasp trials in the simulator: reach a given pre-grasp, close, lift, and judge the grasp by the
//! seed's criterion (§6.5): the hand rises 10 cm and the object is still held.
