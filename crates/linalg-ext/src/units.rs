//! Quantities for people: byte counts in decimal units (the memory
//! budget's messages and its error).

/// Bytes for people: "5.12 TB (5120000000000 bytes)"; decimal units.
pub fn format_bytes(bytes: u64) -> String {
    if bytes == u64::MAX {
        return "more than 18 EB (the size overflows 64 bits)".into();
    }
    const UNITS: [&str; 6] = ["kB", "MB", "GB", "TB", "PB", "EB"];
    if bytes < 1000 {
        return format!("{bytes} bytes");
    }
    let mut v = bytes as f64;
    let mut unit = "";
    for u in UNITS {
        if v < 1000.0 {
            break;
        }
        v /= 1000.0;
        unit = u;
    }
    format!("{v:.3} {unit} ({bytes} bytes)")
}
