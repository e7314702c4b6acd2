use std::path::PathBuf;

use super::write::{DataFlashWriter, PX4_SENSOR_FIELDS, ULogWriter, Value};
use super::*;
use crate::channels::Channels;
use firmware_core::Quantity;
use firmware_core::units::STANDARD_GRAVITY;

/// The real PX4 logs the tests keep (`tests/data/px4-yule-log`).
fn px4(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/data/px4-yule-log")
        .join(name)
}

fn read(path: &Path) -> Result<Option<Recorded>, RecordedError> {
    Recorded::read(path, &mut |_, _| {})
}

/// A ULog of two gyros and an accelerometer, 1 Hz for 20 min, warming 20 → 45 °C; gyro 1's
/// temperature in whole degrees and its device ID changing at 600 s.
fn ulog() -> Vec<u8> {
    ulog_of(2_424_842)
}

/// [`ulog`] with gyro 0's device ID `gyro0_id` (another board's sensor of the same name).
fn ulog_of(gyro0_id: u32) -> Vec<u8> {
    let mut w = ULogWriter::new(Vec::new(), 1_000).unwrap();
    w.format("sensor_gyro", &PX4_SENSOR_FIELDS).unwrap();
    w.format("sensor_accel", &PX4_SENSOR_FIELDS).unwrap();
    w.format(
        "sensor_baro",
        &[("uint64_t", "timestamp"), ("float", "pressure")],
    )
    .unwrap();
    let g0 = w.subscribe("sensor_gyro", 0).unwrap();
    let g1 = w.subscribe("sensor_gyro", 1).unwrap();
    let a0 = w.subscribe("sensor_accel", 0).unwrap();
    let b0 = w.subscribe("sensor_baro", 0).unwrap();
    for i in 0..1200u64 {
        let t_us = 5_000_000 + i * 1_000_000;
        let temp = 20.0 + 25.0 * (i as f32 / 1200.0);
        let sample = |id: u32, temp: f32, xyz: [f32; 3]| {
            [
                Value::U64(t_us + 300),
                Value::U64(t_us),
                Value::U32(id),
                Value::F32(xyz[0]),
                Value::F32(xyz[1]),
                Value::F32(xyz[2]),
                Value::F32(temp),
                Value::U32(0),
            ]
        };
        let drift = 1e-4 * (temp - 20.0);
        w.data(g0, &sample(gyro0_id, temp, [drift, -drift, 0.0]))
            .unwrap();
        let id1 = if i < 600 { 3_670_050 } else { 3_670_051 };
        w.data(g1, &sample(id1, temp.round(), [0.0, drift, 0.0]))
            .unwrap();
        w.data(a0, &sample(2_424_842, temp, [0.1, 0.0, -9.79 + drift]))
            .unwrap();
        w.data(b0, &[Value::U64(t_us), Value::F32(101_325.0)])
            .unwrap();
    }
    w.into_inner()
}

/// A DataFlash log whose `IMU` messages are defined (type 129), as ArduPilot defines them.
fn imu_log() -> DataFlashWriter<Vec<u8>> {
    let mut w = DataFlashWriter::new(Vec::new()).unwrap();
    w.define(
        129,
        "IMU",
        "QBffffffIIfBBHH",
        "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz",
    )
    .unwrap();
    w
}

/// One `IMU` message of instance `imu` at `t_us`: gyro x, y, z (rad/s), then the accelerometer's
/// (m/s²), and the temperature.
fn imu_message(w: &mut DataFlashWriter<Vec<u8>>, t_us: u64, imu: u8, axes: [f32; 6], temp: f32) {
    let mut v = vec![Value::U64(t_us), Value::U8(imu)];
    v.extend(axes.map(Value::F32));
    v.extend([Value::U32(0), Value::U32(0), Value::F32(temp)]);
    v.extend([
        Value::U8(1),
        Value::U8(1),
        Value::U16(1000),
        Value::U16(1000),
    ]);
    w.write(129, &v).unwrap();
}

/// A DataFlash log of two IMUs, 1 Hz for 20 min, warming 20 → 45 °C.
fn dataflash() -> Vec<u8> {
    let mut w = imu_log();
    w.define(130, "BARO", "Qf", "TimeUS,Press").unwrap();
    for i in 0..1200u64 {
        let temp = 20.0 + 25.0 * (i as f32 / 1200.0);
        for imu in 0..2u8 {
            let g = 2e-4 * (temp - 20.0) * f32::from(imu + 1);
            let axes = [g, 0.0, -g, 0.05, -0.02, -9.8 + g];
            imu_message(&mut w, i * 1_000_000, imu, axes, temp);
        }
        w.write(130, &[Value::U64(i * 1_000_000), Value::F32(101_325.0)])
            .unwrap();
    }
    w.into_inner()
}

fn file(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn a_log_is_told_by_its_content_and_a_file_of_neither_kind_is_refused_with_what_it_is() {
    let dir = tempfile::tempdir().unwrap();
    let csv = file(dir.path(), "a.bin", b"time_s,temp_c\n0,20\n");
    assert_eq!(sniff(&csv).unwrap(), Format::Csv);
    assert_eq!(
        sniff(&file(dir.path(), "x.csv", &ulog())).unwrap(),
        Format::ULog
    );
    assert_eq!(
        sniff(&file(dir.path(), "x.log", &dataflash())).unwrap(),
        Format::DataFlash
    );
    let zip = file(dir.path(), "z.ulg", b"PK\x03\x04\x14\x00\x00\x00\x08\x00");
    let e = sniff(&zip).unwrap_err().to_string();
    assert!(
        e.contains("neither a CSV, a PX4 ULog nor an ArduPilot DataFlash log")
            && e.contains("50 4B 03 04 14 00 00 00 (a zip archive)"),
        "{e}"
    );
    assert!(read(&csv).unwrap().is_none());
    // Where a CSV is read, a log is refused as what it is.
    let e = crate::stream::Stream::load(&file(dir.path(), "l.csv", &ulog()), &[])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("a PX4 ULog, not a CSV: give it to --stream"),
        "{e}"
    );
    let e = crate::stream::Stream::load(&zip, &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("(a zip archive)"), "{e}");
}

#[test]
fn the_real_px4_logs_are_read_with_their_sensor_topics_and_what_they_lack_said() {
    let log = read(&px4("sample_log_small.ulg")).unwrap().unwrap();
    assert_eq!(log.format, Format::ULog);
    assert_eq!(log.damage, None);
    let names: Vec<&str> = log.sensors.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(
        names,
        ["gyro0", "gyro1", "gyro2", "accel0", "accel1", "accel2"]
    );
    assert_eq!(
        log.listing(),
        "gyro0 (ID 2424842), gyro1 (ID 3670050), gyro2 (ID 2621474), accel0 (ID 2424842), \
         accel1 (ID 3670050), accel2 (ID 2621474)"
    );
    for s in &log.sensors {
        assert_eq!(s.len(), 6, "{}", s.name);
        assert_eq!(s.temp_c.len(), 6);
        assert_eq!(s.axes.len(), 3);
    }
    let g0 = &log.sensors[0];
    assert!(
        g0.temp_c.iter().all(|t| (40.0..40.4).contains(t)),
        "{:?}",
        g0.temp_c
    );
    let baro: Vec<&str> = log.others.iter().map(|(t, _)| t.as_str()).collect();
    assert!(
        baro.contains(&"sensor_baro[0]") && baro.contains(&"sensor_baro[1]"),
        "{baro:?}"
    );
    let notes = log.notes();
    assert_eq!(notes.len(), 2, "{notes:#?}");
    assert!(
        notes[0].contains(
            "spans under the 10 °C a thermal calibration needs: gyro0 0.3 °C (40.0 to 40.4), \
             gyro1 0.1 °C"
        ),
        "{}",
        notes[0]
    );
    assert!(
        notes[1].contains("also holds sensor_baro[0] (6), sensor_baro[1] (6)"),
        "{}",
        notes[1]
    );
    // The crate's other log holds no sensor: said, with what it holds.
    let e = read(&px4("trig_stats.ulg")).unwrap_err().to_string();
    assert!(
        e.contains("a PX4 ULog with no gyro or accelerometer samples"),
        "{e}"
    );
}

#[test]
fn each_instance_of_a_ulog_is_a_unit_of_its_axes_in_the_projects_units() {
    let dir = tempfile::tempdir().unwrap();
    let path = file(dir.path(), "cal.ulg", &ulog());
    let log = read(&path).unwrap().unwrap();
    let names: Vec<&str> = log.sensors.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["gyro0", "gyro1", "accel0"]);
    assert_eq!(log.others, [("sensor_baro[0]".to_owned(), 1200)]);
    let g0 = &log.sensors[0];
    assert_eq!(g0.device_id, Some(2_424_842));
    assert_eq!(g0.time_s[0], 5.0, "timestamp_sample, not timestamp");
    assert_eq!(
        g0.field_source(g0.time_field),
        "sensor_gyro[0].timestamp_sample"
    );
    assert_eq!(g0.field_source(g0.axes[2].field), "sensor_gyro[0].z");
    let last = g0.len() - 1;
    let rad = f64::from(1e-4f32 * (20.0 + 25.0 * (1199.0f32 / 1200.0) - 20.0));
    assert!((g0.axes[0].values[last] - rad.to_degrees()).abs() < 1e-6);
    let notes = log.notes();
    assert_eq!(notes.len(), 3, "{notes:#?}");
    assert!(notes[0].contains("the temperature of gyro1 is quantized to whole degrees"));
    assert!(
        notes[1].contains("the device ID changes: gyro1 at 600.0 s (3670050 to 3670051)"),
        "{}",
        notes[1]
    );
    // The accelerometer's references: gravity along z, as the board sits.
    let units = Channels::of_log(&log, &["accel0".to_owned()]).unwrap();
    let refs: Vec<String> = units[0]
        .list
        .iter()
        .map(|c| c.reference.to_string())
        .collect();
    assert_eq!(
        refs,
        ["the constant 0", "the constant 0", "the constant -9.80665"]
    );
    let streams = units[0].load_log(&path, &[]).unwrap();
    assert_eq!(streams.len(), 3);
    assert_eq!(streams[2].rate_dps[0], -STANDARD_GRAVITY);
    assert_eq!(units[0].sensor_id, "accel0 2424842");
    // A held-out log read for a sensor of this one: the same device, or refused as another.
    let gyro0 = &Channels::of_log(&log, &["gyro0".to_owned()]).unwrap()[0];
    let again = file(dir.path(), "held.ulg", &ulog());
    assert_eq!(gyro0.load_log(&again, &[]).unwrap().len(), 3);
    let other = file(dir.path(), "other.ulg", &ulog_of(2_424_843));
    let e = gyro0.load_log(&other, &[]).unwrap_err().to_string();
    assert!(
        e.contains("its gyro0 is device 2424843") && e.contains("another sensor"),
        "{e}"
    );
    let e = Channels::of_log(&log, &["gyro7".to_owned()])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no sensor 'gyro7' (it holds: gyro0 (ID 2424842)"),
        "{e}"
    );
}

#[test]
fn a_log_cut_by_a_power_loss_is_read_up_to_the_damage_named_with_its_byte_offset() {
    let dir = tempfile::tempdir().unwrap();
    // Each second of the logs is a group of messages of this many bytes: 3 sensor samples of 45
    // and a barometer's of 17; 2 IMU messages of 54 and a barometer's of 15.
    for (name, bytes, message, second) in [
        ("cut.ulg", ulog(), 45u64, 152usize),
        ("cut.bin", dataflash(), 54, 123),
    ] {
        let whole = read(&file(dir.path(), name, &bytes)).unwrap().unwrap();
        let n = whole.sensors[0].len();
        // Torn inside the last message.
        let cut = &bytes[..bytes.len() - 7];
        let log = read(&file(dir.path(), name, cut)).unwrap().unwrap();
        let d = log.damage.clone().unwrap();
        assert!(d.offset > 0 && d.offset < cut.len() as u64);
        assert!(cut.len() as u64 - d.offset < message, "{d:?}");
        assert!(d.what.contains("cut after"), "{d:?}");
        assert!(log.sensors[0].len() >= n - 1);
        let note = &log.notes()[0];
        assert!(
            note.contains(&format!("unreadable from byte {}", d.offset)),
            "{note}"
        );
        // Corrupt at the start of second 600: read up to there, nothing after it taken for a
        // message.
        let mut bad = bytes.clone();
        let at = bytes.len() - 600 * second;
        bad[at..at + 4].copy_from_slice(&[0xFF; 4]);
        let log = read(&file(dir.path(), name, &bad)).unwrap().unwrap();
        let d = log.damage.clone().unwrap();
        assert_eq!(d.offset, at as u64, "{d:?}");
        assert!(d.what.contains("corrupt from here"), "{d:?}");
        assert!(log.sensors.iter().all(|s| s.len() == 600), "{name}");
    }
    // Cut inside the header: refused, named.
    let e = read(&file(dir.path(), "h.ulg", &ulog()[..12]))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("damaged before any sensor sample: at byte 0"),
        "{e}"
    );
}

#[test]
fn each_imu_of_a_dataflash_log_is_a_unit_of_its_gyro_and_accelerometer_axes() {
    let dir = tempfile::tempdir().unwrap();
    let path = file(dir.path(), "cal.bin", &dataflash());
    let log = read(&path).unwrap().unwrap();
    assert_eq!(log.format, Format::DataFlash);
    assert_eq!(log.listing(), "imu0, imu1");
    assert_eq!(log.others, [("BARO".to_owned(), 1200)]);
    let imu1 = &log.sensors[1];
    let axes: Vec<&str> = imu1.axes.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(axes, ["gyr.x", "gyr.y", "gyr.z", "acc.x", "acc.y", "acc.z"]);
    let fields: Vec<&str> = imu1.axes.iter().map(|a| a.field).collect();
    assert_eq!(fields, ["GyrX", "GyrY", "GyrZ", "AccX", "AccY", "AccZ"]);
    assert_eq!(imu1.field_source(imu1.time_field), "IMU[1].TimeUS");
    assert_eq!(imu1.field_source(imu1.temp_field), "IMU[1].T");
    assert_eq!(imu1.len(), 1200);
    let g = f64::from(2e-4f32 * (20.0 + 25.0 * (600.0f32 / 1200.0) - 20.0) * 2.0);
    assert!((imu1.axes[0].values[600] - g.to_degrees()).abs() < 1e-6);
    assert_eq!(log.notes().len(), 1, "{:?}", log.notes());
    let units = Channels::of_log(&log, &[]).unwrap();
    assert_eq!(units.len(), 2);
    assert_eq!(units[1].list[5].quantity, Quantity::SpecificForce);
    assert_eq!(units[1].sensor_id, "imu1");
}

/// A ULog of one gyro at 100 Hz for `minutes`, warming 20 → 45 °C: a long log.
fn long_ulog(minutes: u64) -> Vec<u8> {
    let mut w = ULogWriter::new(Vec::new(), 1_000).unwrap();
    w.format("sensor_gyro", &PX4_SENSOR_FIELDS).unwrap();
    let g0 = w.subscribe("sensor_gyro", 0).unwrap();
    let n = minutes * 60 * 100;
    for i in 0..n {
        let t_us = i * 10_000;
        let temp = 20.0 + 25.0 * (i as f32 / n as f32);
        let v = [
            Value::U64(t_us + 300),
            Value::U64(t_us),
            Value::U32(2_424_842),
            Value::F32(1e-4 * (temp - 20.0)),
            Value::F32(0.0),
            Value::F32(0.0),
            Value::F32(temp),
            Value::U32(0),
        ];
        w.data(g0, &v).unwrap();
    }
    w.into_inner()
}

#[test]
fn a_long_reads_progress_is_heard_in_order_up_to_the_whole_file() {
    let dir = tempfile::tempdir().unwrap();
    // 45 min at 100 Hz: about 12 MB, so the bar moves twice (every 4 MiB) before it ends.
    let bytes = long_ulog(45);
    let path = file(dir.path(), "long.ulg", &bytes);
    let mut heard: Vec<(u64, u64)> = Vec::new();
    let log = Recorded::read(&path, &mut |done, total| heard.push((done, total)))
        .unwrap()
        .unwrap();
    assert_eq!(log.sensors[0].len(), 270_000);
    let total = bytes.len() as u64;
    assert!(heard.len() >= 3, "{heard:?}");
    assert!(heard.iter().all(|&(_, t)| t == total));
    assert!(
        heard.windows(2).all(|w| w[0].0 <= w[1].0),
        "not in order: {heard:?}"
    );
    assert_eq!(heard.last(), Some(&(total, total)));
    // A short one hears only its end.
    let short = file(dir.path(), "cal.bin", &dataflash());
    let mut heard = Vec::new();
    Recorded::read(&short, &mut |done, total| heard.push((done, total))).unwrap();
    let size = std::fs::metadata(&short).unwrap().len();
    assert_eq!(heard, [(size, size)]);
}

/// ArduPilot's temperature learning logs its means (`TCLR`) beside the `IMU` messages: each
/// instance and sensor type is a sensor of its own, in the project's units, whose long intervals
/// (a row per 0.5 °C of warming) are no gap. They record the `IMU` sensors again, so a command
/// takes them only when they are named, or where the log holds nothing else.
#[test]
fn the_temperature_learnings_means_are_sensors_taken_when_named() {
    const TCLR: u8 = 131;
    let rows = |with_imu: bool| {
        let mut log = if with_imu {
            dataflash()
        } else {
            DataFlashWriter::new(Vec::new()).unwrap().into_inner()
        };
        let mut w = DataFlashWriter::new(Vec::new()).unwrap();
        w.define(TCLR, "TCLR", "QBBffffI", "TimeUS,I,SType,Temp,X,Y,Z,NSamp")
            .unwrap();
        // Rows ever further apart, as a board settles warm.
        let mut t = 0u64;
        for k in 0..30u64 {
            t += 20_000_000 * (1 + k / 5);
            for kind in 0..2u8 {
                let v = [0.001 * k as f32, 0.0, -0.002 * k as f32];
                let mut row = vec![
                    Value::U64(t),
                    Value::U8(1),
                    Value::U8(kind),
                    Value::F32(20.0 + 0.5 * k as f32),
                ];
                row.extend(v.map(Value::F32));
                row.push(Value::U32(100));
                w.write(TCLR, &row).unwrap();
            }
        }
        // The format of formats once: the second writer's own is left out.
        let bytes = w.into_inner();
        log.extend_from_slice(&bytes[89..]);
        log
    };
    let dir = tempfile::tempdir().unwrap();
    let log = read(&file(dir.path(), "learned.bin", &rows(true)))
        .unwrap()
        .unwrap();
    let names: Vec<&str> = log.sensors.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["imu0", "imu1", "tclr-accel1", "tclr-gyro1"]);
    let taken: Vec<&str> = log.taken().map(|s| s.name.as_str()).collect();
    assert_eq!(taken, ["imu0", "imu1"]);
    let gyro = &log.sensors[3];
    assert!(gyro.learned && gyro.topic == "TCLR" && gyro.temp_field == "Temp");
    assert_eq!(gyro.len(), 30);
    assert_eq!(gyro.axes[0].quantity, Quantity::AngularRate);
    let deg = 0.029f32.to_degrees() as f64;
    assert!(
        (gyro.axes[0].values[29] - deg).abs() < 1e-5,
        "{:?}",
        gyro.axes[0]
    );
    assert_eq!(log.sensors[2].axes[2].quantity, Quantity::SpecificForce);
    assert!((log.sensors[2].axes[2].values[29] + 0.058).abs() < 1e-6);
    assert!(gyro.streams(&[0.0; 3])[0].time_issues.is_empty());
    let note = log.notes().join("\n");
    assert!(
        note.contains("temperature learning logged (TCLR)")
            && note.contains("tclr-accel1, tclr-gyro1; taken when named"),
        "{note}"
    );
    let named = Channels::of_log(&log, &["tclr-gyro1".to_owned()]).unwrap();
    assert_eq!(named[0].sensor_id, "tclr-gyro1");
    // A log of learning rows alone: they are what it holds, and taken.
    let alone = read(&file(dir.path(), "alone.bin", &rows(false)))
        .unwrap()
        .unwrap();
    assert_eq!(alone.taken().count(), 2);
    assert_eq!(Channels::of_log(&alone, &[]).unwrap().len(), 2);
    assert!(!alone.notes().join("\n").contains("TCLR"));
}

/// A board logged with ArduPilot's temperature correction on (`INS_TCAL1_ENABLE` 1): its `IMU`
/// messages are what the correction left. The log's `PARM` messages say what it was, and it is
/// undone on reading, so the samples are the sensor's own again, said in one line. A board
/// mounted rotated logs the vehicle's axes: they are turned back to the board's first, where the
/// parameters apply, and said. With a rotation that cannot be turned back (a custom one whose
/// angles the log does not give) the parameters' axes are not the log's: the correction is left
/// in, and said.
#[test]
fn a_correction_the_autopilot_applied_while_logging_is_undone() {
    const PARM: u8 = 132;
    // The sensor's own gyro x of IMU 0 at T, rad/s, and the correction's polynomial.
    let own = |t: f64| 2e-4 * (t - 20.0);
    let (c1, c2, cal) = (150.0, -2.0, 25.0);
    let poly = |t: f64| {
        let d = t.clamp(10.0, 50.0) - 35.0;
        (c1 * d + c2 * d * d) * 1e-6
    };
    let log = |orientation: f32| {
        let mut w = imu_log();
        w.define(PARM, "PARM", "QNf", "TimeUS,Name,Value").unwrap();
        for (name, value) in [
            ("AHRS_ORIENTATION", orientation),
            ("INS_TCAL1_ENABLE", 1.0),
            ("INS_TCAL1_TMIN", 10.0),
            ("INS_TCAL1_TMAX", 50.0),
            ("INS_TCAL1_GYR1_X", c1 as f32),
            ("INS_TCAL1_GYR2_X", c2 as f32),
            ("INS_GYR1_CALTEMP", cal as f32),
            ("INS_TCAL2_ENABLE", 0.0),
        ] {
            w.write(PARM, &[Value::U64(0), Value::name(name), Value::F32(value)])
                .unwrap();
        }
        for i in 0..1200u64 {
            let temp = 5.0 + 50.0 * (i as f64 / 1200.0);
            for imu in 0..2u8 {
                // What the firmware logs: its own output less the correction, on IMU 0 only.
                let applied = if imu == 0 {
                    poly(temp) - poly(cal)
                } else {
                    0.0
                };
                // Logged in the vehicle's axes: yaw 180° (4) negates x and y.
                let x = own(temp) - applied;
                let x = if orientation == 4.0 { -x } else { x };
                let axes = [x, 0.0, 0.0, 0.0, 0.0, -9.8].map(|x| x as f32);
                imu_message(&mut w, i * 1_000_000, imu, axes, temp as f32);
            }
        }
        w.into_inner()
    };
    let dir = tempfile::tempdir().unwrap();
    let read_log = |name, orientation| {
        read(&file(dir.path(), name, &log(orientation)))
            .unwrap()
            .unwrap()
    };
    let undone = read_log("on.bin", 0.0);
    let [imu0, imu1] = [&undone.sensors[0], &undone.sensors[1]];
    assert_eq!(imu0.correction, Some(Correction::Undone));
    assert_eq!(imu1.correction, None);
    // Own output, in °/s, to f32's precision: below 5 °C and above 50 °C too, where the
    // firmware clipped the temperature.
    let worst = |s: &Sensor, own: &dyn Fn(f64) -> f64| {
        s.temp_c
            .iter()
            .zip(&s.axes[0].values)
            .map(|(&t, &v)| (v - own(t).to_degrees()).abs())
            .fold(0.0, f64::max)
    };
    assert!(worst(imu0, &own) < 1e-6, "{}", worst(imu0, &own));
    assert!(worst(imu1, &own) < 1e-6);
    let notes = undone.notes().join("\n");
    assert!(
        notes.contains("temperature correction on (INS_TCALn_ENABLE 1): imu0; the correction")
            && notes.contains("undone"),
        "{notes}"
    );
    let turned = read_log("rotated.bin", 4.0);
    let [imu0, imu1] = [&turned.sensors[0], &turned.sensors[1]];
    assert_eq!(imu0.correction, Some(Correction::Undone));
    assert!(matches!(&imu0.mounting, Some(Mounting::TurnedBack(r)) if r.id == 4));
    assert!(worst(imu0, &own) < 1e-6, "{}", worst(imu0, &own));
    assert!(worst(imu1, &own) < 1e-6);
    // Gravity stays on z through a yaw.
    assert!(imu0.axes[5].values.iter().all(|&z| (z + 9.8).abs() < 1e-5));
    let notes = turned.notes().join("\n");
    assert!(
        notes.contains("mounted rotated in the vehicle: imu0 (AHRS_ORIENTATION 4, YAW_180), imu1"),
        "{notes}"
    );
    let left = read_log("custom.bin", 101.0);
    assert_eq!(left.sensors[0].correction, Some(Correction::Left));
    assert_eq!(left.sensors[0].mounting, Some(Mounting::Unknown(101.0)));
    let logged = |t: f64| own(t) - (poly(t) - poly(cal));
    assert!(worst(&left.sensors[0], &logged) < 1e-6);
    let notes = left.notes().join("\n");
    assert!(
        notes.contains("cannot be turned back: imu0; the correction is left in")
            && notes.contains("imu0 (AHRS_ORIENTATION 101), imu1 (AHRS_ORIENTATION 101); its axes are left as logged"),
        "{notes}"
    );
}
