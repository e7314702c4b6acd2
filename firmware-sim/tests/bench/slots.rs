//! Two calibration slots on simulated NOR flash (issue 22): an update cut by a power loss at
//! every byte of its work, and a bit flipped anywhere in either slot, always boot a valid model —
//! the old one or the new one, whole, never none and never a mix. And (issue 46) with a driver
//! that fails any one read, erase or program, then loses power anywhere: still the old or the
//! new, never none, never an older one; a layout that does not fit the device is refused before
//! anything is touched.

use firmware_core::blob;
use firmware_core::slots::{self, Booted, Flash, FlashError, Layout, LayoutError, Slot, SlotError};
use firmware_core::{BlobError, Model, Quantity, StaticUnit};
use firmware_sim::flash::NorFlash;

/// 4 KiB sectors, 256-byte pages: a common serial NOR.
type Nor = NorFlash<4096, 256>;
/// The capacities of docs/firmware.md's 24-centre model (d = 2, p = 7).
type Gyro = Model<2, 14, 395>;

/// One sector per slot: the 24-centre blob is 1,646 bytes.
const LAYOUT: Layout = Layout {
    a: 0,
    b: 4096,
    len: 4096,
};

/// The firmware-integration example's model, as exported.
const OLD: &[u8] = include_bytes!("../../../firmware-core/doc/gyro.bin");
/// The same model as a format-4 blob (before the error model).
const V4: &[u8] = include_bytes!("../../../firmware-core/doc/gyro-v4.bin");

/// Another calibration of the same gyro: the same blob with one kernel weight 0.1% larger.
fn recalibrated() -> Vec<u8> {
    let mut b = OLD.to_vec();
    // The floats end before the rule beyond the range (one byte), the error model and the
    // limits; the weights start after 7d + p + 2 + m·d = 71 of them.
    let tail = 1 + 4 * (firmware_core::ErrorModel::NUMBERS + blob::Limits::NUMBERS);
    let at = b.len() - tail - 4 * 395 + 4 * 71;
    let w = f32::from_le_bytes(b[at..at + 4].try_into().unwrap()) * 1.001;
    b[at..at + 4].copy_from_slice(&w.to_le_bytes());
    blob::reseal(&mut b);
    b
}

/// What a boot took: where from, and the model it decoded.
#[derive(Debug)]
struct Took {
    slot: Slot,
    sequence: u32,
    model: Gyro,
}

fn boot(flash: &Nor) -> Result<Took, SlotError> {
    let mut model = Gyro::new();
    let Booted { slot, sequence } = slots::boot(flash, &LAYOUT, &mut [0u8; 4096], &mut model)?;
    Ok(Took {
        slot,
        sequence,
        model,
    })
}

fn update(flash: &mut Nor, blob: &[u8]) -> Result<(Slot, u32), SlotError> {
    slots::update::<_, Gyro>(flash, &LAYOUT, &mut blob.to_vec(), &mut [0u8; 4096])
}

/// The blob an update with this sequence number writes: the two calibrations alternate.
fn blob_of(sequence: u32) -> Vec<u8> {
    if sequence % 2 == 1 {
        OLD.to_vec()
    } else {
        recalibrated()
    }
}

/// The model that sequence number holds.
fn model_of(sequence: u32) -> Gyro {
    Gyro::decode(&blob_of(sequence)).unwrap()
}

/// The device after `n` updates.
fn after_updates(n: u32) -> Nor {
    assert_ne!(model_of(1), model_of(2));
    let mut flash = Nor::new(2);
    for k in 1..=n {
        assert_eq!(update(&mut flash, &blob_of(k)).unwrap().1, k);
    }
    flash
}

#[test]
fn boot_takes_the_newest_valid_slot_and_an_update_writes_the_other() {
    let empty = Nor::new(2);
    assert_eq!(boot(&empty).unwrap_err(), SlotError::NoValidSlot);
    let mut flash = after_updates(2);
    let booted = boot(&flash).unwrap();
    assert_eq!((booted.slot, booted.sequence), (Slot::B, 2));
    assert_eq!(booted.model, model_of(2));
    assert_eq!(update(&mut flash, &blob_of(3)).unwrap(), (Slot::A, 3));
    assert_eq!(boot(&flash).unwrap().slot, Slot::A);
}

#[test]
fn a_power_cut_at_every_byte_of_an_update_boots_the_old_model_or_the_new() {
    // The second update writes B while A is in use; the third writes A while B is.
    for before in [1, 2] {
        let flash = after_updates(before);
        let next = blob_of(before + 1);
        let mut whole = flash.clone();
        update(&mut whole, &next).unwrap();
        let work = whole.worked() - flash.worked();
        assert_eq!(
            work,
            4096 + next.len(),
            "a sector erased, the blob programmed"
        );
        for cut in 0..=work {
            let mut f = flash.clone();
            f.cut_after(cut);
            let written = update(&mut f, &next);
            f.power_on();
            let booted = boot(&f).unwrap_or_else(|e| panic!("cut at {cut}: no model ({e})"));
            // The magic is the last work: the new model exists once all of it is there.
            let committed = cut == work;
            assert_eq!(written.is_ok(), committed, "cut at {cut}");
            let expected = if committed { before + 1 } else { before };
            assert_eq!(booted.sequence, expected, "cut at {cut}");
            assert_eq!(booted.model, model_of(expected), "cut at {cut}");
        }
    }
}

#[test]
fn a_driver_that_fails_once_then_loses_power_never_loses_the_model_nor_rolls_it_back() {
    // The first install, A → B, and B → A (the model in use in B, an older one in A).
    for before in [0, 1, 2] {
        let flash = if before == 0 {
            Nor::new(2)
        } else {
            after_updates(before)
        };
        let next = blob_of(before + 1);
        let mut whole = flash.clone();
        whole.fail_once(usize::MAX);
        update(&mut whole, &next).unwrap();
        let (ops, work) = (whole.ops(), whole.worked() - flash.worked());
        let mut cases = 0;
        for fail in 0..ops {
            for cut in (0..=work).step_by(3).chain([work]) {
                let mut f = flash.clone();
                f.fail_once(fail);
                f.cut_after(cut);
                let written = update(&mut f, &next);
                f.power_on();
                f.fail_once(usize::MAX);
                let what = format!("{before}: operation {fail} failed, power cut at {cut}");
                match boot(&f) {
                    Ok(b) => {
                        assert!(
                            b.sequence == before || b.sequence == before + 1,
                            "{what}: booted {}",
                            b.sequence
                        );
                        assert_eq!(b.model, model_of(b.sequence), "{what}");
                        if written.is_ok() {
                            assert_eq!(b.sequence, before + 1, "{what}");
                        }
                    }
                    Err(e) => assert_eq!(before, 0, "{what}: no model ({e})"),
                }
                cases += 1;
            }
        }
        assert!(cases > 5_000, "{cases}");
    }
}

#[test]
fn a_boot_whose_read_fails_says_so_rather_than_boot_the_older_model() {
    let flash = after_updates(2);
    for fail in 0..2 {
        let mut f = flash.clone();
        f.fail_once(fail);
        let mut model = Gyro::new();
        model.decode_into(&blob_of(1)).unwrap();
        let e = slots::boot(&f, &LAYOUT, &mut [0u8; 4096], &mut model).unwrap_err();
        assert_eq!(e, SlotError::Flash(FlashError::Device), "read {fail}");
        assert_eq!(model, Gyro::new(), "no stale model after a failed boot");
        // Tried again, it boots the newest.
        assert_eq!(boot(&f).unwrap().sequence, 2);
    }
}

#[test]
fn a_layout_that_does_not_fit_the_device_is_refused_before_anything_is_touched() {
    let mut flash = Nor::new(4);
    update(&mut flash, &blob_of(1)).unwrap();
    let size = flash.size();
    let bad = [
        (
            Layout {
                a: 0,
                b: 4096,
                len: 0,
            },
            LayoutError::Empty,
        ),
        (
            Layout {
                a: 0,
                b: 5000,
                len: 5000,
            },
            LayoutError::NotWholeSectors,
        ),
        (
            Layout {
                a: 0,
                b: 4096,
                len: 4095,
            },
            LayoutError::NotWholeSectors,
        ),
        (
            Layout {
                a: 100,
                b: 4096,
                len: 4096,
            },
            LayoutError::Unaligned,
        ),
        (
            Layout {
                a: 0,
                b: 4100,
                len: 4096,
            },
            LayoutError::Unaligned,
        ),
        (
            Layout {
                a: 0,
                b: 0,
                len: 4096,
            },
            LayoutError::Overlap,
        ),
        (
            Layout {
                a: 0,
                b: 4096,
                len: 8192,
            },
            LayoutError::Overlap,
        ),
        (
            Layout {
                a: 8192,
                b: 4096,
                len: 8192,
            },
            LayoutError::Overlap,
        ),
        (
            Layout {
                a: 0,
                b: size,
                len: 4096,
            },
            LayoutError::OutsideDevice,
        ),
        (
            Layout {
                a: 0,
                b: 4096,
                len: size,
            },
            LayoutError::OutsideDevice,
        ),
        (
            Layout {
                a: usize::MAX - 4095,
                b: 0,
                len: 4096,
            },
            LayoutError::OutsideDevice,
        ),
        (
            Layout {
                a: usize::MAX - 4094,
                b: 0,
                len: 4096,
            },
            LayoutError::Unaligned,
        ),
        (
            Layout {
                a: 0,
                b: usize::MAX / 4096 * 4096,
                len: 8192,
            },
            LayoutError::OutsideDevice,
        ),
    ];
    for (layout, why) in bad {
        let mut f = flash.clone();
        f.fail_once(usize::MAX);
        let e = slots::update::<_, Gyro>(&mut f, &layout, &mut blob_of(2), &mut [0u8; 8192]);
        assert_eq!(e, Err(SlotError::Layout(why)), "{layout:?}");
        assert_eq!(
            (f.ops(), f.worked()),
            (0, flash.worked()),
            "{layout:?}: touched"
        );
        let mut model = Gyro::new();
        let e = slots::boot(&f, &layout, &mut [0u8; 8192], &mut model).unwrap_err();
        assert_eq!(e, SlotError::Layout(why), "{layout:?}");
    }
}

#[test]
fn a_flipped_bit_in_either_slot_boots_the_other() {
    let flash = after_updates(2);
    let len = OLD.len();
    for (slot, base, survivor) in [(Slot::A, LAYOUT.a, 2), (Slot::B, LAYOUT.b, 1)] {
        for byte in 0..len {
            for bit in 0..8 {
                let mut f = flash.clone();
                f.flip(base + byte, bit);
                let booted = boot(&f).unwrap_or_else(|e| panic!("{slot:?} {byte}.{bit}: {e}"));
                assert_eq!(booted.sequence, survivor, "{slot:?} byte {byte} bit {bit}");
                assert_eq!(booted.model, model_of(survivor));
            }
        }
    }
}

#[test]
fn an_update_refuses_what_could_not_boot_before_erasing_anything() {
    let flash = after_updates(1);
    let mut corrupt = recalibrated();
    corrupt[100] ^= 1;
    let mut f = flash.clone();
    assert_eq!(
        update(&mut f, &corrupt).unwrap_err(),
        SlotError::Blob(BlobError::CrcMismatch)
    );
    let mut v3 = V4[..10].to_vec();
    v3[4] = 3;
    let payload = &V4[blob::HEADER_LEN..];
    v3.extend(u32::try_from(payload.len()).unwrap().to_le_bytes());
    v3.extend(crc32(payload).to_le_bytes());
    v3.extend(payload);
    assert_eq!(
        Gyro::decode(&v3).unwrap(),
        Gyro::decode(V4).unwrap(),
        "version 3 still decodes"
    );
    assert_eq!(
        update(&mut f, &v3).unwrap_err(),
        SlotError::Blob(BlobError::NoSequence(3))
    );
    assert_eq!(f, flash, "nothing written");
}

/// CRC-32/ISO-HDLC, the version-3 blob's checksum.
fn crc32(bytes: &[u8]) -> u32 {
    crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(bytes)
}

/// A six-channel unit: an IMU's axes, each channel one of the two calibrations.
type Imu = StaticUnit<6, 2, 14, { 6 * 395 }>;

/// Three sectors a slot: the six-channel blob is 10 KB.
const UNIT_LAYOUT: Layout = Layout {
    a: 0,
    b: 3 * 4096,
    len: 3 * 4096,
};

/// The unit blob an update with this sequence number writes: the calibrations alternate.
fn unit_blob_of(sequence: u32) -> Vec<u8> {
    let model = blob_of(sequence);
    let names = ["gyro.x", "gyro.y", "gyro.z", "acc.x", "acc.y", "acc.z"];
    let channels: Vec<blob::unit::ChannelBlob<'_>> = names
        .iter()
        .enumerate()
        .map(|(k, name)| blob::unit::ChannelBlob {
            name,
            quantity: if k < 3 {
                Quantity::AngularRate
            } else {
                Quantity::SpecificForce
            },
            model: &model,
        })
        .collect();
    let mut buf = vec![0u8; 4 * 4096];
    let n = blob::unit::encode("IMU-7", [-30.0, 60.0], &channels, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

fn boot_unit(flash: &Nor) -> Result<(u32, Imu), SlotError> {
    let mut unit = Imu::new();
    let b = slots::boot(flash, &UNIT_LAYOUT, &mut [0u8; 3 * 4096], &mut unit)?;
    Ok((b.sequence, unit))
}

fn update_unit(flash: &mut Nor, blob: &[u8]) -> Result<(Slot, u32), SlotError> {
    slots::update::<_, Imu>(
        flash,
        &UNIT_LAYOUT,
        &mut blob.to_vec(),
        &mut [0u8; 3 * 4096],
    )
}

#[test]
fn a_power_cut_at_every_byte_of_a_six_channel_units_update_boots_the_old_unit_or_the_new() {
    let decoded = |sequence| {
        let mut u = Imu::new();
        u.decode_into(&unit_blob_of(sequence)).unwrap();
        u
    };
    assert_ne!(decoded(1), decoded(2));
    assert_eq!(Imu::check(&unit_blob_of(1)), Ok(6));
    let mut flash = Nor::new(6);
    for k in 1..=2 {
        assert_eq!(update_unit(&mut flash, &unit_blob_of(k)).unwrap().1, k);
    }
    let next = unit_blob_of(3);
    let mut whole = flash.clone();
    update_unit(&mut whole, &next).unwrap();
    let work = whole.worked() - flash.worked();
    assert_eq!(
        work,
        3 * 4096 + next.len(),
        "three sectors erased, the blob programmed"
    );
    // The old unit and the new, decoded once; every cut on one of two threads.
    let (old, new) = (decoded(2), decoded(3));
    let cuts = |flash: Nor, range: std::ops::RangeInclusive<usize>| {
        for cut in range {
            let mut f = flash.clone();
            f.cut_after(cut);
            let written = update_unit(&mut f, &next);
            f.power_on();
            let (sequence, unit) =
                boot_unit(&f).unwrap_or_else(|e| panic!("cut at {cut}: no unit ({e})"));
            let committed = cut == work;
            assert_eq!(written.is_ok(), committed, "cut at {cut}");
            let (expected, booted) = if committed { (3, &new) } else { (2, &old) };
            assert_eq!(sequence, expected, "cut at {cut}");
            assert_eq!(&unit, booted, "cut at {cut}");
            assert_eq!(unit.channels().len(), 6);
        }
    };
    std::thread::scope(|s| {
        let before = flash.clone();
        let other = s.spawn(|| cuts(before, 0..=work / 2));
        cuts(flash.clone(), work / 2 + 1..=work);
        other.join().unwrap();
    });
    // A model's storage refuses the unit blob of six channels before anything is erased (it
    // takes a unit blob of one).
    let mut f = flash.clone();
    assert_eq!(
        slots::update::<_, Gyro>(
            &mut f,
            &UNIT_LAYOUT,
            &mut next.clone(),
            &mut [0u8; 3 * 4096]
        ),
        Err(SlotError::Blob(BlobError::CapacityExceeded {
            what: firmware_core::error::Storage::Channels,
            needed: 6,
            capacity: 1
        }))
    );
    assert_eq!(f, flash);
}
