//! ArduPilot's board rotations: how a flight controller mounted turned in the vehicle is told
//! (`AHRS_ORIENTATION`, the `Rotation` enum of its `AP_Math/rotations.h`), and the turn itself.
//!
//! ArduPilot's `IMU` messages hold the vehicle's axes: the firmware turns each sample by the
//! board's rotation after its temperature correction, whose parameters (`INS_TCALn_*`) are in the
//! board's axes. A thermal calibration must therefore turn the logged axes back first, as
//! `tempcal_IMU.py` does, or a board mounted yaw 90° would get its x curve written as y.

/// Each rotation's name and (roll, pitch, yaw) in degrees, by its `AHRS_ORIENTATION` value: the
/// matrix is ArduPilot's `Matrix3::from_euler` (yaw, then pitch, then roll, 3-2-1). Rotation 38 is
/// named for rounded angles; the firmware's are roll 90°, pitch 68.8°, yaw 293.3°.
const TABLE: [(&str, f64, f64, f64); 44] = [
    ("NONE", 0.0, 0.0, 0.0),
    ("YAW_45", 0.0, 0.0, 45.0),
    ("YAW_90", 0.0, 0.0, 90.0),
    ("YAW_135", 0.0, 0.0, 135.0),
    ("YAW_180", 0.0, 0.0, 180.0),
    ("YAW_225", 0.0, 0.0, 225.0),
    ("YAW_270", 0.0, 0.0, 270.0),
    ("YAW_315", 0.0, 0.0, 315.0),
    ("ROLL_180", 180.0, 0.0, 0.0),
    ("ROLL_180_YAW_45", 180.0, 0.0, 45.0),
    ("ROLL_180_YAW_90", 180.0, 0.0, 90.0),
    ("ROLL_180_YAW_135", 180.0, 0.0, 135.0),
    ("PITCH_180", 0.0, 180.0, 0.0),
    ("ROLL_180_YAW_225", 180.0, 0.0, 225.0),
    ("ROLL_180_YAW_270", 180.0, 0.0, 270.0),
    ("ROLL_180_YAW_315", 180.0, 0.0, 315.0),
    ("ROLL_90", 90.0, 0.0, 0.0),
    ("ROLL_90_YAW_45", 90.0, 0.0, 45.0),
    ("ROLL_90_YAW_90", 90.0, 0.0, 90.0),
    ("ROLL_90_YAW_135", 90.0, 0.0, 135.0),
    ("ROLL_270", 270.0, 0.0, 0.0),
    ("ROLL_270_YAW_45", 270.0, 0.0, 45.0),
    ("ROLL_270_YAW_90", 270.0, 0.0, 90.0),
    ("ROLL_270_YAW_135", 270.0, 0.0, 135.0),
    ("PITCH_90", 0.0, 90.0, 0.0),
    ("PITCH_270", 0.0, 270.0, 0.0),
    ("PITCH_180_YAW_90", 0.0, 180.0, 90.0),
    ("PITCH_180_YAW_270", 0.0, 180.0, 270.0),
    ("ROLL_90_PITCH_90", 90.0, 90.0, 0.0),
    ("ROLL_180_PITCH_90", 180.0, 90.0, 0.0),
    ("ROLL_270_PITCH_90", 270.0, 90.0, 0.0),
    ("ROLL_90_PITCH_180", 90.0, 180.0, 0.0),
    ("ROLL_270_PITCH_180", 270.0, 180.0, 0.0),
    ("ROLL_90_PITCH_270", 90.0, 270.0, 0.0),
    ("ROLL_180_PITCH_270", 180.0, 270.0, 0.0),
    ("ROLL_270_PITCH_270", 270.0, 270.0, 0.0),
    ("ROLL_90_PITCH_180_YAW_90", 90.0, 180.0, 90.0),
    ("ROLL_90_YAW_270", 90.0, 0.0, 270.0),
    ("ROLL_90_PITCH_68_YAW_293", 90.0, 68.8, 293.3),
    ("PITCH_315", 0.0, 315.0, 0.0),
    ("ROLL_90_PITCH_315", 90.0, 315.0, 0.0),
    ("PITCH_7", 0.0, 7.0, 0.0),
    ("ROLL_45", 45.0, 0.0, 0.0),
    ("ROLL_315", 315.0, 0.0, 0.0),
];

/// The custom rotations (`AHRS_ORIENTATION` 100, 101, 102) and the parameters that hold their
/// roll, pitch and yaw: the old one's under `AHRS_CUSTOM_`, the two of `AP_CustomRotations`
/// under `CUST_ROT1_` and `CUST_ROT2_`.
const CUSTOM: [(u16, &str); 3] = [
    (100, "AHRS_CUSTOM_"),
    (101, "CUST_ROT1_"),
    (102, "CUST_ROT2_"),
];

/// The suffixes of a custom rotation's three parameters after its prefix, in angle order.
const AXES: [&str; 3] = ["ROLL", "PITCH", "YAW"];

/// Whether a parameter is one a board rotation is read from.
pub(super) fn is_parameter(name: &str) -> bool {
    name == "AHRS_ORIENTATION" || CUSTOM.iter().any(|(_, prefix)| name.starts_with(prefix))
}

/// A board's rotation in the vehicle: its `AHRS_ORIENTATION` value, its name and its matrix (the
/// board's axes to the vehicle's).
#[derive(Debug, Clone, PartialEq)]
pub struct BoardRotation {
    /// The `AHRS_ORIENTATION` value.
    pub id: u16,
    /// ArduPilot's name less its `ROTATION_` prefix (`YAW_90`), or `CUSTOM (roll r, pitch p,
    /// yaw y)`.
    pub name: String,
    matrix: [[f64; 3]; 3],
    /// A custom rotation's roll, pitch and yaw, degrees, as its parameters give them.
    custom: Option<[f64; 3]>,
}

impl BoardRotation {
    /// The rotation `AHRS_ORIENTATION` = `id` names; a custom one's angles are read with
    /// `parameter` (by name, as the log's `PARM` messages set them). `None` where `id` is no
    /// rotation ArduPilot defines, or a custom one whose angles the log does not give.
    pub fn ardupilot(id: u16, parameter: impl Fn(&str) -> Option<f64>) -> Option<Self> {
        if let Some(&(name, roll, pitch, yaw)) = TABLE.get(usize::from(id)) {
            return Some(Self::from_euler(id, name.to_owned(), [roll, pitch, yaw]));
        }
        let (_, prefix) = CUSTOM.iter().find(|(custom, _)| *custom == id)?;
        let angle = |axis: &str| parameter(&format!("{prefix}{axis}")).filter(|a| a.is_finite());
        let [roll, pitch, yaw] = AXES.map(angle);
        let angles = [roll?, pitch?, yaw?];
        let name = format!(
            "CUSTOM (roll {}°, pitch {}°, yaw {}°)",
            angles[0], angles[1], angles[2]
        );
        Some(Self {
            custom: Some(angles),
            ..Self::from_euler(id, name, angles)
        })
    }

    /// The custom rotation `id` (100 to 102) of `angles` (roll, pitch, yaw, degrees), as a log
    /// whose parameters give those angles names it; `None` for any other `id`.
    pub fn custom(id: u16, angles: [f64; 3]) -> Option<Self> {
        if usize::from(id) < TABLE.len() {
            return None;
        }
        Self::ardupilot(id, |name| {
            let k = AXES.iter().position(|axis| name.ends_with(axis))?;
            angles.get(k).copied()
        })
    }

    /// The parameters besides `AHRS_ORIENTATION` that a log must set for a reader to know this
    /// rotation: a custom one's roll, pitch and yaw (`CUST_ROT1_ROLL` …), none for the table's.
    pub fn parameters(&self) -> Vec<(String, f64)> {
        let Some((angles, (_, prefix))) = self
            .custom
            .zip(CUSTOM.iter().find(|(custom, _)| *custom == self.id))
        else {
            return Vec::new();
        };
        AXES.iter()
            .zip(angles)
            .map(|(axis, angle)| (format!("{prefix}{axis}"), angle))
            .collect()
    }

    /// ArduPilot's `Matrix3::from_euler` of angles in degrees, the entries that are 0 or ±1 but
    /// for rounding made exact, so that a right-angle turn only swaps and negates axes.
    fn from_euler(id: u16, name: String, [roll, pitch, yaw]: [f64; 3]) -> Self {
        let (sr, cr) = roll.to_radians().sin_cos();
        let (sp, cp) = pitch.to_radians().sin_cos();
        let (sy, cy) = yaw.to_radians().sin_cos();
        let exact = |x: f64| {
            let r = x.round();
            if (x - r).abs() < 1e-12 { r } else { x }
        };
        let matrix = [
            [cp * cy, sr * sp * cy - cr * sy, cr * sp * cy + sr * sy],
            [cp * sy, sr * sp * sy + cr * cy, cr * sp * sy - sr * cy],
            [-sp, sr * cp, cr * cp],
        ]
        .map(|row| row.map(exact));
        Self {
            id,
            name,
            matrix,
            custom: None,
        }
    }

    /// Whether it turns nothing (`NONE`, or a custom rotation of zero angles).
    pub fn is_identity(&self) -> bool {
        (0..3).all(|i| (0..3).all(|j| self.matrix[i][j] == f64::from(u8::from(i == j))))
    }

    /// A vector in the board's axes, in the vehicle's (what the firmware logs).
    pub fn turn(&self, v: [f64; 3]) -> [f64; 3] {
        self.matrix
            .map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
    }

    /// A vector in the vehicle's axes, in the board's (the transpose: what `tempcal_IMU.py`'s
    /// `rotate_by_inverse_id` does).
    pub fn turn_back(&self, v: [f64; 3]) -> [f64; 3] {
        let m = &self.matrix;
        [0, 1, 2].map(|j| m[0][j] * v[0] + m[1][j] * v[1] + m[2][j] * v[2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-12)
    }

    /// The turns ArduPilot's `Vector3::rotate` writes out case by case, checked on a few.
    #[test]
    fn the_table_turns_as_ardupilots_rotate_does() {
        let v = [1.0, 2.0, 3.0];
        let turn = |id| BoardRotation::ardupilot(id, |_| None).unwrap().turn(v);
        assert_eq!(turn(0), v);
        // YAW_90: x = -y, y = x.
        assert_eq!(turn(2), [-2.0, 1.0, 3.0]);
        // YAW_180: x = -x, y = -y.
        assert_eq!(turn(4), [-1.0, -2.0, 3.0]);
        // ROLL_180: y = -y, z = -z.
        assert_eq!(turn(8), [1.0, -2.0, -3.0]);
        // ROLL_90: y = -z, z = y.
        assert_eq!(turn(16), [1.0, -3.0, 2.0]);
        // PITCH_90: x = z, z = -x.
        assert_eq!(turn(24), [3.0, 2.0, -1.0]);
        // ROLL_90_PITCH_90: tmp = z; z = y; y = -tmp, then x = z, z = -x.
        assert_eq!(turn(28), [2.0, -3.0, -1.0]);
        // YAW_45: x = (x - y)/√2, y = (x + y)/√2.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!(close(turn(1), [-h, 3.0 * h, 3.0]));
    }

    #[test]
    fn turning_back_undoes_every_rotation_and_keeps_lengths() {
        let v = [0.3, -1.7, 9.81];
        for id in (0..TABLE.len() as u16).chain([100, 101, 102]) {
            let r = BoardRotation::ardupilot(id, |name| {
                name.ends_with("ROLL")
                    .then_some(10.0)
                    .or(Some(if name.ends_with("YAW") { 250.0 } else { -30.0 }))
            })
            .unwrap();
            let there = r.turn(v);
            assert!(close(r.turn_back(there), v), "{}", r.name);
            let len = |a: [f64; 3]| a.iter().map(|x| x * x).sum::<f64>().sqrt();
            assert!((len(there) - len(v)).abs() < 1e-12, "{}", r.name);
        }
        assert!(BoardRotation::ardupilot(0, |_| None).unwrap().is_identity());
        assert!(!BoardRotation::ardupilot(2, |_| None).unwrap().is_identity());
    }

    #[test]
    fn an_unknown_rotation_or_a_custom_one_without_its_angles_is_none() {
        assert!(BoardRotation::ardupilot(44, |_| None).is_none());
        assert!(BoardRotation::ardupilot(101, |_| None).is_none());
        let custom = BoardRotation::ardupilot(101, |name| match name {
            "CUST_ROT1_ROLL" => Some(0.0),
            "CUST_ROT1_PITCH" => Some(0.0),
            "CUST_ROT1_YAW" => Some(90.0),
            _ => None,
        })
        .unwrap();
        assert_eq!(custom.turn([1.0, 2.0, 3.0]), [-2.0, 1.0, 3.0]);
        // Made from its angles it is the same; a table rotation takes none.
        assert_eq!(
            BoardRotation::custom(101, [0.0, 0.0, 90.0]),
            Some(custom.clone())
        );
        assert_eq!(BoardRotation::custom(2, [0.0, 0.0, 90.0]), None);
        // The parameters it names read back as the same rotation; the table's need none.
        let named = custom.parameters();
        let again = BoardRotation::ardupilot(101, |name| {
            named.iter().find(|(n, _)| n == name).map(|(_, v)| *v)
        });
        assert_eq!(again, Some(custom));
        assert!(
            BoardRotation::ardupilot(2, |_| None)
                .unwrap()
                .parameters()
                .is_empty()
        );
        assert!(is_parameter("CUST_ROT2_YAW") && is_parameter("AHRS_ORIENTATION"));
        assert!(!is_parameter("INS_TCAL1_ENABLE"));
    }
}
