//! NOR flash, simulated closely enough to cut its power anywhere: what the calibration slots
//! ([`firmware_core::slots`]) are tested against.
//!
//! What NOR does and this does: an erase sets a whole sector to 0xFF; programming can only clear
//! bits (the stored byte becomes `old & new`), within one page per operation; reads see the cells
//! as they are. A power cut stops the work at a byte: the bytes before it are done, the byte it
//! falls on is half done (an erase has set only its low four bits, a program has cleared only
//! the low four of the bits it should), the rest are untouched, and every later erase or program
//! fails until the power comes back ([`NorFlash::power_on`]). Erases proceed byte by byte from
//! the sector's start, so a cut erase leaves a sector part erased and part old.
//!
//! And as a driver can: any one operation (a read, an erase or a program, counted from
//! [`NorFlash::fail_once`]) reports a device failure and does nothing, once.

use std::cell::Cell;

use firmware_core::slots::{Flash, FlashError};

/// A NOR device of `SECTOR`-byte sectors and `PAGE`-byte pages. Two devices are equal when their
/// cells are.
#[derive(Debug, Clone)]
pub struct NorFlash<const SECTOR: usize, const PAGE: usize> {
    cells: Vec<u8>,
    /// Bytes the device may still erase or program before the power goes (`None`: unlimited).
    budget: Option<usize>,
    /// Bytes erased or programmed since the count was last reset.
    worked: usize,
    powered: bool,
    /// Operations since [`Self::fail_once`], and which of them fails.
    ops: Cell<usize>,
    fail_at: Option<usize>,
}

impl<const SECTOR: usize, const PAGE: usize> PartialEq for NorFlash<SECTOR, PAGE> {
    fn eq(&self, other: &Self) -> bool {
        self.cells == other.cells
    }
}

impl<const SECTOR: usize, const PAGE: usize> Eq for NorFlash<SECTOR, PAGE> {}

impl<const SECTOR: usize, const PAGE: usize> NorFlash<SECTOR, PAGE> {
    /// An erased device of `sectors` sectors.
    pub fn new(sectors: usize) -> Self {
        Self {
            cells: vec![0xFF; sectors * SECTOR],
            budget: None,
            worked: 0,
            powered: true,
            ops: Cell::new(0),
            fail_at: None,
        }
    }

    /// Operation `k` from now (0: the next read, erase or program) reports a device failure and
    /// does nothing; the others work.
    pub fn fail_once(&mut self, k: usize) {
        self.ops.set(0);
        self.fail_at = Some(k);
    }

    /// Operations since [`Self::fail_once`] (or since the device was made).
    pub fn ops(&self) -> usize {
        self.ops.get()
    }

    /// Counts an operation; whether it is the one that fails.
    fn fails(&self) -> bool {
        let k = self.ops.get();
        self.ops.set(k + 1);
        self.fail_at == Some(k)
    }

    /// The power goes after `bytes` more bytes of erase or program work.
    pub fn cut_after(&mut self, bytes: usize) {
        self.budget = Some(bytes);
    }

    /// Power back: no cut pending, erases and programs work again.
    pub fn power_on(&mut self) {
        self.budget = None;
        self.powered = true;
    }

    /// Whether the power went during the work since [`Self::cut_after`].
    pub fn lost_power(&self) -> bool {
        !self.powered
    }

    /// Bytes erased or programmed so far: an update's length in cut points.
    pub fn worked(&self) -> usize {
        self.worked
    }

    /// Flips one bit, as radiation or a worn cell might.
    pub fn flip(&mut self, addr: usize, bit: u8) {
        if let Some(c) = self.cells.get_mut(addr) {
            *c ^= 1 << (bit % 8);
        }
    }

    /// The device's contents.
    pub fn cells(&self) -> &[u8] {
        &self.cells
    }

    /// One byte of work on `cell`: `full` when the power holds, `half` on the byte it goes.
    /// Returns whether the power held.
    fn work(&mut self, addr: usize, full: impl Fn(u8) -> u8, half: impl Fn(u8) -> u8) -> bool {
        let Some(cell) = self.cells.get_mut(addr) else {
            return false;
        };
        match &mut self.budget {
            Some(0) => {
                *cell = half(*cell);
                self.powered = false;
                return false;
            }
            Some(left) => *left -= 1,
            None => {}
        }
        *cell = full(*cell);
        self.worked += 1;
        true
    }
}

impl<const SECTOR: usize, const PAGE: usize> Flash for NorFlash<SECTOR, PAGE> {
    fn size(&self) -> usize {
        self.cells.len()
    }

    fn sector(&self) -> usize {
        SECTOR
    }

    fn page(&self) -> usize {
        PAGE
    }

    fn read(&self, addr: usize, buf: &mut [u8]) -> Result<(), FlashError> {
        if self.fails() {
            return Err(FlashError::Device);
        }
        let src = self
            .cells
            .get(addr..addr + buf.len())
            .ok_or(FlashError::OutOfRange)?;
        buf.copy_from_slice(src);
        Ok(())
    }

    fn erase(&mut self, addr: usize) -> Result<(), FlashError> {
        if !addr.is_multiple_of(SECTOR) || addr + SECTOR > self.cells.len() {
            return Err(FlashError::OutOfRange);
        }
        if self.fails() || !self.powered {
            return Err(FlashError::Device);
        }
        for a in addr..addr + SECTOR {
            if !self.work(a, |_| 0xFF, |c| c | 0x0F) {
                return Err(FlashError::Device);
            }
        }
        Ok(())
    }

    fn program(&mut self, addr: usize, data: &[u8]) -> Result<(), FlashError> {
        let end = addr + data.len();
        if end > self.cells.len() || (!data.is_empty() && addr / PAGE != (end - 1) / PAGE) {
            return Err(FlashError::OutOfRange);
        }
        if self.fails() || !self.powered {
            return Err(FlashError::Device);
        }
        for (a, &v) in (addr..end).zip(data) {
            if !self.work(a, |c| c & v, |c| c & (v | 0xF0)) {
                return Err(FlashError::Device);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type Nor = NorFlash<16, 4>;

    #[test]
    fn erase_sets_ones_and_programming_only_clears_bits() {
        let mut f = Nor::new(2);
        f.program(0, &[0x0F, 0xF0]).unwrap();
        f.program(0, &[0xFF, 0x3C]).unwrap();
        assert_eq!(&f.cells()[..3], &[0x0F, 0x30, 0xFF]);
        assert_eq!(f.erase(3), Err(FlashError::OutOfRange));
        assert_eq!(
            f.program(2, &[0, 0, 0]),
            Err(FlashError::OutOfRange),
            "crosses a page"
        );
        f.erase(0).unwrap();
        assert!(f.cells()[..16].iter().all(|&c| c == 0xFF));
    }

    #[test]
    fn a_power_cut_leaves_a_half_done_byte_and_stops_all_work() {
        let mut f = Nor::new(2);
        f.program(16, &[0x00; 4]).unwrap();
        f.cut_after(2);
        assert_eq!(f.program(0, &[0x00; 4]), Err(FlashError::Device));
        assert_eq!(&f.cells()[..4], &[0x00, 0x00, 0xF0, 0xFF]);
        assert!(f.lost_power());
        assert_eq!(f.erase(16), Err(FlashError::Device));
        assert_eq!(&f.cells()[16..20], &[0x00; 4]);
        f.power_on();
        f.cut_after(1);
        assert_eq!(f.erase(16), Err(FlashError::Device));
        assert_eq!(&f.cells()[16..19], &[0xFF, 0x0F, 0x00]);
    }
}
