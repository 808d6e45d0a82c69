//! The `.msg` definitions of the messages in [`crate::msg`], and their concatenated form with every
//! type they use (the `ros2msg` schema encoding rosbag2 writes into MCAP: the type's text, then for
//! each type it uses, depth first and once, a line of 80 `=`, `MSG: package/Type` and its text).
//!
//! The texts are those of ROS 2 Humble's interface packages without their comments (field names,
//! types and order are what CDR needs; Iron and Jazzy have the same fields except
//! `visualization_msgs/Marker`, whose three later texture fields a reader takes from the schema a
//! recording carries).

/// (type name `package/msg/Type`, definition) of the standard messages pbd speaks.
pub const STANDARD: &[(&str, &str)] = &[
    ("builtin_interfaces/msg/Time", "int32 sec\nuint32 nanosec\n"),
    ("builtin_interfaces/msg/Duration", "int32 sec\nuint32 nanosec\n"),
    (
        "std_msgs/msg/Header",
        "builtin_interfaces/Time stamp\nstring frame_id\n",
    ),
    ("std_msgs/msg/String", "string data\n"),
    ("std_msgs/msg/Float64", "float64 data\n"),
    ("std_msgs/msg/ColorRGBA", "float32 r\nfloat32 g\nfloat32 b\nfloat32 a\n"),
    (
        "std_msgs/msg/MultiArrayDimension",
        "string label\nuint32 size\nuint32 stride\n",
    ),
    (
        "std_msgs/msg/MultiArrayLayout",
        "std_msgs/MultiArrayDimension[] dim\nuint32 data_offset\n",
    ),
    (
        "std_msgs/msg/Float64MultiArray",
        "std_msgs/MultiArrayLayout layout\nfloat64[] data\n",
    ),
    ("geometry_msgs/msg/Vector3", "float64 x\nfloat64 y\nfloat64 z\n"),
    ("geometry_msgs/msg/Point", "float64 x\nfloat64 y\nfloat64 z\n"),
    (
        "geometry_msgs/msg/Quaternion",
        "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
    ),
    (
        "geometry_msgs/msg/Pose",
        "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n",
    ),
    (
        "geometry_msgs/msg/PoseStamped",
        "std_msgs/Header header\ngeometry_msgs/Pose pose\n",
    ),
    (
        "geometry_msgs/msg/Transform",
        "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n",
    ),
    (
        "geometry_msgs/msg/TransformStamped",
        "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n",
    ),
    (
        "geometry_msgs/msg/Wrench",
        "geometry_msgs/Vector3 force\ngeometry_msgs/Vector3 torque\n",
    ),
    (
        "geometry_msgs/msg/WrenchStamped",
        "std_msgs/Header header\ngeometry_msgs/Wrench wrench\n",
    ),
    (
        "tf2_msgs/msg/TFMessage",
        "geometry_msgs/TransformStamped[] transforms\n",
    ),
    (
        "sensor_msgs/msg/JointState",
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n",
    ),
    (
        "sensor_msgs/msg/Image",
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data\n",
    ),
    (
        "sensor_msgs/msg/CompressedImage",
        "std_msgs/Header header\nstring format\nuint8[] data\n",
    ),
    (
        // foxglove_msgs (ROS 2 package of Foxglove's schemas): one frame of a video stream.
        "foxglove_msgs/msg/CompressedVideo",
        "builtin_interfaces/Time timestamp\nstring frame_id\nuint8[] data\nstring format\n",
    ),
    (
        "sensor_msgs/msg/RegionOfInterest",
        "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n",
    ),
    (
        "sensor_msgs/msg/CameraInfo",
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\nfloat64[] d\n\
         float64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\nuint32 binning_y\n\
         sensor_msgs/RegionOfInterest roi\n",
    ),
    (
        "trajectory_msgs/msg/JointTrajectoryPoint",
        "float64[] positions\nfloat64[] velocities\nfloat64[] accelerations\nfloat64[] effort\n\
         builtin_interfaces/Duration time_from_start\n",
    ),
    (
        "trajectory_msgs/msg/JointTrajectory",
        "std_msgs/Header header\nstring[] joint_names\ntrajectory_msgs/JointTrajectoryPoint[] points\n",
    ),
    (
        "visualization_msgs/msg/Marker",
        "int32 ARROW=0\nint32 CUBE=1\nint32 SPHERE=2\nint32 CYLINDER=3\nint32 LINE_STRIP=4\n\
         int32 LINE_LIST=5\nint32 CUBE_LIST=6\nint32 SPHERE_LIST=7\nint32 POINTS=8\n\
         int32 TEXT_VIEW_FACING=9\nint32 MESH_RESOURCE=10\nint32 TRIANGLE_LIST=11\nint32 ADD=0\n\
         int32 MODIFY=0\nint32 DELETE=2\nint32 DELETEALL=3\nstd_msgs/Header header\nstring ns\n\
         int32 id\nint32 type\nint32 action\ngeometry_msgs/Pose pose\ngeometry_msgs/Vector3 scale\n\
         std_msgs/ColorRGBA color\nbuiltin_interfaces/Duration lifetime\nbool frame_locked\n\
         geometry_msgs/Point[] points\nstd_msgs/ColorRGBA[] colors\nstring text\n\
         string mesh_resource\nbool mesh_use_embedded_materials\n",
    ),
    (
        "visualization_msgs/msg/MarkerArray",
        "visualization_msgs/Marker[] markers\n",
    ),
    (
        "rcl_interfaces/msg/Log",
        "byte DEBUG=10\nbyte INFO=20\nbyte WARN=30\nbyte ERROR=40\nbyte FATAL=50\n\
         builtin_interfaces/Time stamp\nuint8 level\nstring name\nstring msg\nstring file\n\
         string function\nuint32 line\n",
    ),
];

/// The primitive types of the `.msg` language (anything else names a message).
const PRIMITIVES: [&str; 17] = [
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
    "uint64", "string", "wstring", "time", "duration",
];

/// `package/Type` or `package/msg/Type` as `package/msg/Type`.
pub fn normalize(name: &str) -> String {
    match name.split('/').collect::<Vec<_>>()[..] {
        [package, ty] => format!("{package}/msg/{ty}"),
        _ => name.to_owned(),
    }
}

/// `package/msg/Type` as `package/Type` (the form of `MSG:` lines).
fn denormalize(name: &str) -> String {
    name.replacen("/msg/", "/", 1)
}

/// The message types a definition's fields use (constants and primitives left out), in order,
/// normalised; a bare `Type` is `package`'s own.
pub fn field_types(package: &str, text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        let Some((ty, rest)) = line.split_once(char::is_whitespace) else {
            continue;
        };
        // A constant (`int32 ARROW=0`): its value follows `=` after the type.
        if rest.contains('=') {
            continue;
        }
        let base = ty.split('[').next().unwrap_or(ty);
        if PRIMITIVES.contains(&base) {
            continue;
        }
        let name = if base.contains('/') {
            normalize(base)
        } else {
            format!("{package}/msg/{base}")
        };
        if !out.contains(&name) {
            out.push(name);
        }
    }
    out
}

/// The concatenated definition of `name` (`package/msg/Type`) with every type it uses, looked up
/// in `tables` in order; `None` when a type is in none of them.
pub fn concatenated(name: &str, tables: &[&[(&'static str, &'static str)]]) -> Option<String> {
    let lookup = |n: &str| {
        tables
            .iter()
            .flat_map(|t| t.iter())
            .find(|(k, _)| *k == n)
            .map(|(_, v)| *v)
    };
    let mut out = lookup(name)?.to_owned();
    let mut seen = vec![name.to_owned()];
    // Depth first, each type once (rosbag2's order).
    fn visit(
        name: &str,
        lookup: &dyn Fn(&str) -> Option<&'static str>,
        seen: &mut Vec<String>,
        out: &mut String,
    ) -> Option<()> {
        let package = name.split('/').next().unwrap_or("");
        for dep in field_types(package, lookup(name)?) {
            if seen.contains(&dep) {
                continue;
            }
            seen.push(dep.clone());
            let text = lookup(&dep)?;
            out.push_str(&"=".repeat(80));
            out.push_str("\nMSG: ");
            out.push_str(&denormalize(&dep));
            out.push('\n');
            out.push_str(text);
            visit(&dep, lookup, seen, out)?;
        }
        Some(())
    }
    visit(name, &lookup, &mut seen, &mut out)?;
    Some(out)
}

/// [`concatenated`] over the [`STANDARD`] messages.
pub fn standard(name: &str) -> Option<String> {
    concatenated(name, &[STANDARD])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_standard_type_resolves() {
        for (name, _) in STANDARD {
            assert!(standard(name).is_some(), "{name}");
        }
    }

    #[test]
    fn constants_and_primitives_are_not_types() {
        let log = STANDARD.iter().find(|(n, _)| *n == "rcl_interfaces/msg/Log").unwrap().1;
        assert_eq!(field_types("rcl_interfaces", log), ["builtin_interfaces/msg/Time"]);
        let info = STANDARD
            .iter()
            .find(|(n, _)| *n == "sensor_msgs/msg/CameraInfo")
            .unwrap()
            .1;
        assert_eq!(
            field_types("sensor_msgs", info),
            ["std_msgs/msg/Header", "sensor_msgs/msg/RegionOfInterest"]
        );
    }

    #[test]
    fn wrench_stamped_concatenates_depth_first_once() {
        let text = standard("geometry_msgs/msg/WrenchStamped").unwrap();
        let names: Vec<&str> = text.lines().filter_map(|l| l.strip_prefix("MSG: ")).collect();
        assert_eq!(
            names,
            [
                "std_msgs/Header",
                "builtin_interfaces/Time",
                "geometry_msgs/Wrench",
                "geometry_msgs/Vector3"
            ]
        );
    }
}
