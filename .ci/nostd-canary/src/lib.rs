//! no_std canary: `cargo check -p manylights-nostd-canary`. If anything in manylights'
//! dependency graph links std, std's panic handler collides with the one below (E0152).
#![no_std]

extern crate alloc;

pub use manylights;

#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    loop {}
}
