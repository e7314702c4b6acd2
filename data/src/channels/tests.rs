//! The channels file read, refused and mapped, on small files written here.

use super::*;

const IMU: &str = r#"
sensor_id = "IMU-0042"
time = "timestamp*1e-6"
temperature = "imu.temperature"

[[channel]]
name = "gyro.x"
output = "imu.gyro.x"
unit = "rad/s"
reference = "0"

[[channel]]
name = "acc.z"
output = "imu.acc.z"
unit = "m/s2"
reference = "-9.80665"

[[channel]]
name = "coil"
output = "counts*2"
unit = "counts"
reference = "rig_rate"
scale_factor = 26592.6
"#;

#[test]
fn a_channels_file_names_each_channel_once() {
    let c = Channels::parse(Path::new("imu.toml"), IMU).unwrap();
    assert_eq!(c.sensor_id, "IMU-0042");
    assert_eq!(c.len(), 3);
    let [gx, az, coil] = &c.list[..] else {
        panic!()
    };
    assert_eq!(gx.quantity, Quantity::AngularRate);
    assert_eq!(
        gx.output,
        ColumnSource::Column {
            name: "imu.gyro.x".into(),
            factor: 180.0 / std::f64::consts::PI
        }
    );
    assert_eq!(gx.bias_scale_factor(), Some(1.0));
    assert_eq!(az.quantity, Quantity::SpecificForce);
    assert_eq!(az.reference, ColumnSource::Constant(-9.80665));
    assert_eq!(coil.quantity, Quantity::AngularRate);
    assert_eq!(coil.unit, OutputUnit::Raw("counts".into()));
    assert_eq!(coil.bias_scale_factor(), Some(26592.6));
    let maps = c.maps(1, &[], Read::Log).unwrap();
    let names: Vec<&str> = maps.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["time_s", "temp_c", "voltage_v", "rate_dps"]);
    // A rate table keeps its own time.
    let segment = ["time_s=segment*21".parse().unwrap()];
    let maps = c.maps(1, &segment, Read::Table).unwrap();
    assert_eq!(maps[1].source.to_string(), "column segment × 21");
    // What the file gives, a --map may not give again.
    for bad in ["voltage_v=x", "temp_c=T", "rate_dps=0", "time_s=t"] {
        let e = c.maps(0, &[bad.parse().unwrap()], Read::Log).unwrap_err();
        assert!(e.to_string().contains("given by the channels file"), "{e}");
    }
    assert!(c.maps(0, &["other=x".parse().unwrap()], Read::Log).is_ok());
}

#[test]
fn a_bad_channels_file_says_what_is_wrong() {
    let bad = |text: &str| {
        Channels::parse(Path::new("c.toml"), text)
            .unwrap_err()
            .to_string()
    };
    let one = |fields: &str| format!("[[channel]]\n{fields}\n");
    assert!(bad("").contains("missing field `channel`"), "{}", bad(""));
    assert!(bad("channel = []").contains("no [[channel]]"));
    let e = bad(&one("name = \"x\"\noutput = \"a\"\nunit = \"rad/s\""));
    assert!(e.contains("missing field `reference`"), "{e}");
    let e = bad(&one(
        "name = \"x\"\noutput = \"a\"\nunit = \"rad/s\"\nreference = \"0\"\nspeed = 1",
    ));
    assert!(e.contains("unknown field `speed`"), "{e}");
    let e = bad(
        &(one("name = \"x\"\noutput = \"a\"\nunit = \"rad/s\"\nreference = \"0\"")
            + &one("name = \"x\"\noutput = \"b\"\nunit = \"rad/s\"\nreference = \"0\"")),
    );
    assert!(e.contains("named twice"), "{e}");
    let e = bad(&one(
        "name = \"a name far too long\"\noutput = \"a\"\nunit = \"g\"\nreference = \"0\"",
    ));
    assert!(e.contains("1 to 16 bytes"), "{e}");
    let e = bad(&one(
        "name = \"x\"\noutput = \"a\"\nunit = \"g\"\nreference = \"0\"\nkind = \"gyro\"",
    ));
    assert!(e.contains("not a gyro unit"), "{e}");
    let e = bad(&one(
        "name = \"x\"\noutput = \"3\"\nunit = \"g\"\nreference = \"0\"",
    ));
    assert!(e.contains("is a number, not a column"), "{e}");
    let e = bad(&one(
        "name = \"x\"\noutput = \"a*b\"\nunit = \"g\"\nreference = \"0\"",
    ));
    assert!(e.contains("expected a column"), "{e}");
    let e = bad(&one(
        "name = \"x\"\noutput = \"a\"\nunit = \"V\"\nreference = \"0\"\nscale_factor = 0",
    ));
    assert!(e.contains("not a finite non-zero"), "{e}");
    let base = "name = \"x\"\noutput = \"a\"\nunit = \"deg/s\"\nreference = \"0\"";
    let e = bad(&one(&format!("{base}\nfull_scale = -2000")));
    assert!(
        e.contains("channel 'x': full_scale -2000 is not a positive"),
        "{e}"
    );
    let e = bad(&one(&format!("{base}\nscale_repeatability = 2e6")));
    assert!(
        e.contains("channel 'x': scale_repeatability must be a σ in ppm"),
        "{e}"
    );
}

#[test]
fn a_channel_states_its_own_datasheet() {
    let text = IMU.replace(
        "reference = \"-9.80665\"",
        "reference = \"-9.80665\"\nfull_scale = 160\ntempco = 0.001\nhysteresis = 0.002\nsensor_lag = 90",
    );
    let c = Channels::parse(Path::new("imu.toml"), &text).unwrap();
    let [gx, az, _] = &c.list[..] else { panic!() };
    assert_eq!((gx.full_scale, gx.datasheet), (None, Datasheet::default()));
    assert_eq!(az.full_scale, Some(160.0));
    assert_eq!(
        az.datasheet,
        Datasheet {
            tempco: Some(0.001),
            hysteresis: Some(0.002),
            sensor_lag_s: Some(90.0),
            ..Datasheet::default()
        }
    );
}

#[test]
fn a_units_log_is_read_once_and_a_minute_handled_on_one_channel_is_left_out_of_all() {
    // 10 minutes at 1 Hz of two static channels; the accelerometer is knocked at 300–359 s.
    let mut text = String::from("t,T,gx,az\n");
    for i in 0..600 {
        let ripple = 0.001 * (f64::from(i) * 1.7).sin();
        let knock = if (300..360).contains(&i) {
            (f64::from(i) * 0.9).sin()
        } else {
            0.0
        };
        text.push_str(&format!(
            "{i},{},{},{}\n",
            20.0 + f64::from(i) / 600.0,
            ripple,
            -9.8 + ripple + knock
        ));
    }
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("log.csv");
    std::fs::write(&log, text).unwrap();
    let channels = Channels::parse(
        Path::new("c.toml"),
        "time = \"t\"\ntemperature = \"T\"\n[[channel]]\nname = \"gx\"\noutput = \"gx\"\n\
         unit = \"deg/h\"\nreference = \"0\"\n[[channel]]\nname = \"az\"\noutput = \"az\"\n\
         unit = \"m/s2\"\nreference = \"-9.8\"\n",
    )
    .unwrap();
    let streams = channels.load_log(&log, &[]).unwrap();
    assert_eq!(streams.len(), 2);
    assert_eq!(streams[0].time_s, streams[1].time_s);
    assert!((streams[0].voltage_v[5] - 0.001 * 8.5f64.sin() / 3600.0).abs() < 1e-15);
    assert_eq!(streams[1].voltage_v[0], -9.8);
    for s in &streams {
        assert_eq!(s.handled.len(), 1, "{:?}", s.handled);
        assert_eq!(s.handled[0].span_s, [300.0, 359.0]);
        assert_eq!(s.rate_dps.iter().filter(|r| r.is_nan()).count(), 60);
    }
    // A column that is not there is named by its channel.
    let e = Channels::parse(
        Path::new("c.toml"),
        "time = \"t\"\ntemperature = \"T\"\n[[channel]]\nname = \"gy\"\noutput = \"gy\"\nunit = \"g\"\nreference = \"0\"\n",
    )
    .unwrap()
    .load_log(&log, &[])
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("missing column 'gy'") && e.contains("channel gy's output in c.toml"),
        "{e}"
    );
}

/// One channel's CSV is a unit of one: read as a log of one channel is (`--map` renaming its
/// columns), its lines unlabelled, and `--scale-factor` its channel's; a unit's channels refuse
/// it, and no channel takes a scale factor that is not a finite non-zero number.
#[test]
fn one_channels_csv_is_a_unit_of_one_that_takes_the_scale_factor() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("s.csv");
    let mut csv = String::from("t,temp_c,v,rate_dps\n");
    for k in 0..120 {
        csv.push_str(&format!("{k},25,{},0\n", 0.1 + 1e-3 * f64::from(k)));
    }
    std::fs::write(&log, csv).unwrap();
    let mut one = Channels::single(&log);
    assert_eq!(
        (one.len(), one.label(0), one.heading(0, "°/s")),
        (1, "", String::new())
    );
    let maps: Vec<ColumnMap> = ["time_s=t", "voltage_v=v"]
        .iter()
        .map(|m| m.parse().unwrap())
        .collect();
    let [s] = <[Stream; 1]>::try_from(one.load_log(&log, &maps).unwrap()).unwrap();
    let alone = Stream::load(&log, &maps).unwrap();
    assert_eq!((&s.time_s, &s.voltage_v), (&alone.time_s, &alone.voltage_v));
    assert_eq!(s.voltage_v[119], 0.1 + 1e-3 * 119.0);
    one.take_scale_factor(Some(0.05)).unwrap();
    assert_eq!(one.list[0].bias_scale_factor(), Some(0.05));
    assert!(one.take_scale_factor(Some(0.0)).is_err());
    let mut unit = Channels::parse(Path::new("imu.toml"), IMU).unwrap();
    assert_eq!(unit.heading(1, "m/s²"), "acc.z (m/s², [2/3]):");
    unit.take_scale_factor(None).unwrap();
    let e = unit.take_scale_factor(Some(0.05)).unwrap_err().to_string();
    assert!(e.contains("--scale-factor is for one channel"), "{e}");
}
