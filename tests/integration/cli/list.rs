//! `tmlut list`: the names of the tables.

use super::{stdout, tmlut};

#[test]
fn list_names_every_table() {
    let output = tmlut(&["list"]);
    assert!(output.status.success());
    for table in ["fgd", "gd", "tir", "belcour", "karis", "fgd_rarer", "ggx_e", "ggx_e_avg", "karis_multiscatter"] {
        assert!(stdout(&output).contains(table), "{}", stdout(&output));
    }
}
