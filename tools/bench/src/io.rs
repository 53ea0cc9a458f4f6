//! Issue 2: read speed of the PLY reader.

/// Prints the I/O table.
pub fn report() {
    println!("## I/O (issue 2)");
    println!();
    println!("(being written)");
}
