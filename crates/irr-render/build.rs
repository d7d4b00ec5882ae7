//! With the `denoise` feature: finds Intel Open Image Denoise where OIDN_DIR says (the `oidn`
//! crate links it from there; .cargo/config.toml points OIDN_DIR at the README's set-up folder),
//! fails with the set-up command when it is not there, and records the folder as a run-time
//! search path of this crate's tests, so they start without LD_LIBRARY_PATH.
fn main() {
    println!("cargo::rerun-if-env-changed=OIDN_DIR");
    if std::env::var_os("CARGO_FEATURE_DENOISE").is_none() {
        return;
    }
    let dir = std::env::var_os("OIDN_DIR").unwrap_or_default();
    let lib = std::path::Path::new(&dir).join("lib");
    if !lib.join("libOpenImageDenoise.so").exists()
        && !lib.join("libOpenImageDenoise.dylib").exists()
    {
        println!(
            "cargo::error=the `denoise` feature needs Intel Open Image Denoise in OIDN_DIR ({}): \
             install it with `python3 -m pip install --no-deps --target target/oidn pyoidn==2.5.1` \
             from the workspace root, or set OIDN_DIR to a folder with lib/libOpenImageDenoise",
            lib.display()
        );
        return;
    }
    println!("cargo::rustc-link-arg=-Wl,-rpath,{}", lib.display());
}
