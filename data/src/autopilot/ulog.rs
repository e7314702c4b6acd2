//! A PX4 ULog's sensors: every instance of `sensor_gyro` and `sensor_accel` (rad/s and m/s², with
//! `temperature`, `device_id` and `timestamp_sample`, else `timestamp`), read by `yule_log` from
//! the whole messages [`super::framing`] passes on. Other `sensor_*` topics are counted.

use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::Path;
use std::rc::Rc;

use firmware_core::Quantity;
use yule_log::builder::ULogParserBuilder;
use yule_log::model::inst;
use yule_log::model::msg::UlogMessage;

use super::error::{Damage, Progress, RecordedError, open};
use super::framing::{Filtered, Frame, Framing, read_full};
use super::sensor::{Axis, Collected, Sensor};

/// The topics read as sensors, what they measure and the factor to the project's units.
const SENSORS: [(&str, &str, Quantity, f64); 2] = [
    (
        "sensor_gyro",
        "gyro",
        Quantity::AngularRate,
        180.0 / std::f64::consts::PI,
    ),
    ("sensor_accel", "accel", Quantity::SpecificForce, 1.0),
];

/// The message types of ULog version 1 (its specification), by their type byte.
const TYPES: &[u8] = b"BFIMPQARDLCSO";

/// What the frames showed of the log's topics: each subscription's topic and instance, and how
/// many samples each has.
#[derive(Default)]
struct Topics {
    names: HashMap<u16, (String, u8)>,
    counts: HashMap<u16, usize>,
    wanted: HashSet<u16>,
}

/// ULog framing: the 16-byte header, then `size: u16, type: u8` and `size` bytes per message.
struct Frames {
    header: bool,
    topics: Rc<RefCell<Topics>>,
}

impl Framing for Frames {
    fn next(&mut self, r: &mut impl std::io::Read) -> Result<Frame, String> {
        if !self.header {
            self.header = true;
            let mut head = vec![0u8; 16];
            let n = read_full(r, &mut head)?;
            if n < 16 {
                return Err(format!("the 16-byte header is cut after {n} bytes"));
            }
            return Ok(Frame::Message(head, true));
        }
        let mut msg = vec![0u8; 3];
        match read_full(r, &mut msg)? {
            0 => return Ok(Frame::End),
            3 => {}
            n => return Err(format!("a message header cut after {n} of its 3 bytes")),
        }
        let size = usize::from(u16::from_le_bytes([msg[0], msg[1]]));
        let kind = msg[2];
        if !TYPES.contains(&kind) {
            return Err(format!(
                "an unknown message type 0x{kind:02X} (the bytes are corrupt from here)"
            ));
        }
        msg.resize(3 + size, 0);
        let n = read_full(r, &mut msg[3..])?;
        if n < size {
            return Err(format!(
                "a '{}' message of {size} bytes cut after {n}",
                char::from(kind)
            ));
        }
        let body = &msg[3..];
        let mut topics = self.topics.borrow_mut();
        let keep = match kind {
            b'B' => true,
            // `yule_log` prints formats named *heartbeat* to stdout; no sensor topic uses one.
            b'F' => !body
                .split(|&b| b == b':')
                .next()
                .is_some_and(|name| name.windows(9).any(|w| w == b"heartbeat")),
            b'A' if body.len() >= 3 => {
                let multi = body[0];
                let id = u16::from_le_bytes([body[1], body[2]]);
                let name = String::from_utf8_lossy(&body[3..]).into_owned();
                let wanted = SENSORS.iter().any(|s| s.0 == name);
                if wanted {
                    topics.wanted.insert(id);
                }
                topics.names.insert(id, (name, multi));
                wanted
            }
            b'D' if body.len() >= 2 => {
                let id = u16::from_le_bytes([body[0], body[1]]);
                *topics.counts.entry(id).or_default() += 1;
                topics.wanted.contains(&id)
            }
            _ => false,
        };
        Ok(Frame::Message(msg, keep))
    }
}

/// One instance's samples as they are read.
#[derive(Default)]
struct Samples {
    device_id: Option<u32>,
    id_changes: Vec<(f64, u32)>,
    time_field: &'static str,
    time_s: Vec<f64>,
    temp_c: Vec<f64>,
    has_temperature: bool,
    axes: [Vec<f64>; 3],
}

/// The numeric value of a field, where it is a number.
fn number(v: &inst::FieldValue) -> Option<f64> {
    use inst::FieldValue as V;
    Some(match *v {
        V::ScalarF32(x) => f64::from(x),
        V::ScalarF64(x) => x,
        V::ScalarU64(x) => x as f64,
        V::ScalarU32(x) => f64::from(x),
        V::ScalarI32(x) => f64::from(x),
        V::ScalarU16(x) => f64::from(x),
        V::ScalarI16(x) => f64::from(x),
        V::ScalarU8(x) => f64::from(x),
        V::ScalarI8(x) => f64::from(x),
        _ => return None,
    })
}

/// Reads `path`'s sensors ([`Recorded::read`](super::Recorded::read)).
pub(super) fn read(path: &Path, progress: Progress<'_>) -> Result<Collected, RecordedError> {
    let (file, total) = open(path)?;
    let damage = Rc::new(RefCell::new(None::<Damage>));
    let topics = Rc::new(RefCell::new(Topics::default()));
    let frames = Frames {
        header: false,
        topics: Rc::clone(&topics),
    };
    let filtered = Filtered::new(file, total, frames, Rc::clone(&damage), progress);
    let parsed = ULogParserBuilder::new(filtered)
        .include_timestamp(true)
        .build();
    let mut by_instance: BTreeMap<(usize, u8), Samples> = BTreeMap::new();
    let mut parse_error = None;
    match parsed {
        Err(e) => parse_error = Some(e.to_string()),
        Ok(parser) => {
            for message in parser {
                match message {
                    Ok(UlogMessage::LoggedData(d)) => {
                        let topics = topics.borrow();
                        let Some((name, multi)) = topics.names.get(&d.msg_id) else {
                            continue;
                        };
                        let Some(k) = SENSORS.iter().position(|s| s.0 == name) else {
                            continue;
                        };
                        let s = by_instance.entry((k, *multi)).or_default();
                        push(s, &d.data, d.timestamp, SENSORS[k].3);
                    }
                    Ok(_) => {}
                    Err(e) => {
                        parse_error = Some(e.to_string());
                        break;
                    }
                }
            }
        }
    }
    let mut damage = damage.borrow_mut().take();
    if let (None, Some(what)) = (&damage, parse_error) {
        damage = Some(Damage {
            offset: total,
            what: format!("yule_log: {what}"),
        });
    }
    let topics = topics.borrow();
    let sensors = by_instance
        .into_iter()
        .filter(|(_, s)| !s.time_s.is_empty())
        .map(|((k, multi), s)| {
            let (topic, short, quantity, _) = SENSORS[k];
            Sensor {
                name: format!("{short}{multi}"),
                topic: topic.to_owned(),
                instance: multi,
                device_id: s.device_id,
                id_changes: s.id_changes,
                time_field: s.time_field,
                time_s: s.time_s,
                temp_field: "temperature",
                temp_c: if s.has_temperature {
                    s.temp_c
                } else {
                    Vec::new()
                },
                unreadable: 0,
                learned: false,
                correction: None,
                mounting: None,
                axes: ["x", "y", "z"]
                    .into_iter()
                    .zip(s.axes)
                    .map(|(n, values)| Axis {
                        name: n.to_owned(),
                        field: n,
                        quantity,
                        values,
                    })
                    .collect(),
            }
        })
        .collect();
    let mut others: Vec<(String, usize)> = topics
        .names
        .iter()
        .filter(|(_, (name, _))| {
            name.starts_with("sensor_") && !SENSORS.iter().any(|s| s.0 == name)
        })
        .map(|(id, (name, multi))| {
            (
                format!("{name}[{multi}]"),
                topics.counts.get(id).copied().unwrap_or(0),
            )
        })
        .collect();
    others.sort();
    Ok((sensors, others, damage))
}

/// Appends one logged sample of a sensor topic to its instance's samples.
fn push(s: &mut Samples, data: &inst::Format, timestamp: u64, factor: f64) {
    let mut time = None;
    let mut sample_time = None;
    let mut temperature = None;
    let mut axes = [f64::NAN; 3];
    let mut id = None;
    for f in &data.fields {
        let Some(v) = number(&f.value) else { continue };
        match &*f.name {
            "timestamp" => time = Some(v),
            "timestamp_sample" => sample_time = Some(v),
            "temperature" => temperature = Some(v),
            "device_id" => id = Some(v as u32),
            "x" => axes[0] = v * factor,
            "y" => axes[1] = v * factor,
            "z" => axes[2] = v * factor,
            _ => {}
        }
    }
    if s.time_s.is_empty() {
        // Without either field, the message's own timestamp: ULog's `timestamp` all the same.
        s.time_field = if sample_time.is_some() {
            "timestamp_sample"
        } else {
            "timestamp"
        };
    }
    let t = sample_time.or(time).unwrap_or(timestamp as f64) * 1e-6;
    if let Some(id) = id {
        match s.device_id {
            None => s.device_id = Some(id),
            Some(first) => {
                let last = s.id_changes.last().map_or(first, |c| c.1);
                if id != last {
                    let t0 = s.time_s.first().copied().unwrap_or(t);
                    s.id_changes.push((t - t0, id));
                }
            }
        }
    }
    s.has_temperature |= temperature.is_some();
    s.time_s.push(t);
    s.temp_c.push(temperature.unwrap_or(f64::NAN));
    for (a, v) in s.axes.iter_mut().zip(axes) {
        a.push(v);
    }
}
