//! Stereo vision: ray-cast rendering, background subtraction, segments and their features, triangulation.
