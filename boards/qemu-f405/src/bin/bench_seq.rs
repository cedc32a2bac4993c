//! placeholder
#![no_std]
#![no_main]
use rtseq_qemu_f405 as _;
#[cortex_m_rt::entry]
fn main() -> ! {
    rtseq_qemu_f405::exit_success()
}
