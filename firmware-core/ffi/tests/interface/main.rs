//! The C interface as C sees it: its functions called as C calls them, the committed header, and
//! the calibration slots through C function pointers. One test binary, so that one link serves
//! them all.

mod abi;
mod header;
mod slots;
