//! The meanings of GRBL 1.1's `error:N` and `ALARM:N` codes (from GRBL's own documentation), so a
//! stopped job says what went wrong in words.

/// The meaning of `error:N`.
pub fn error(n: u32) -> &'static str {
    match n {
        1 => "expected command letter: a G-code word has no letter",
        2 => "bad number format: a G-code word's value is missing or not a number",
        3 => "invalid statement: the '$' system command is not recognized or supported",
        4 => "negative value: a value that must be positive is negative",
        5 => "setting disabled: homing is not enabled in the settings ($22)",
        6 => "step pulse too short: the minimum step pulse time must be at least 3 us",
        7 => "EEPROM read failed: the affected settings were restored to their defaults",
        8 => "not idle: the '$' command needs the machine to be idle",
        9 => "G-code lock: G-code is locked out during an alarm or a jog (home or unlock first)",
        10 => "soft limits need homing enabled",
        11 => "line overflow: the line is longer than GRBL takes and was not executed",
        12 => "step rate too high: a '$' setting makes the step rate exceed 30 kHz",
        13 => "check door: the safety door is open",
        14 => "line length exceeded: a build-info or start-up line is too long for EEPROM",
        15 => "travel exceeded: the jog target is outside the machine's travel",
        16 => "invalid jog command",
        17 => "laser mode requires PWM output",
        20 => "unsupported or invalid G-code command in the block",
        21 => "modal group violation: two commands of the same modal group in the block",
        22 => "undefined feed rate",
        23 => "the command requires an integer value",
        24 => "two commands in the block need axis words",
        25 => "a word is repeated in the block",
        26 => "no axis words in a block whose command needs them",
        27 => "invalid line number",
        28 => "the command is missing a required value word",
        29 => "G59.x work coordinate systems are not supported",
        30 => "G53 is only allowed with G0 and G1",
        31 => "axis words in a block where no command uses them",
        32 => "G2/G3 arcs need at least one in-plane axis word",
        33 => "invalid motion target",
        34 => "invalid arc radius",
        35 => "G2/G3 arcs need at least one in-plane offset word",
        36 => "unused value words in the block",
        37 => "G43.1 tool length offset is not on the configured tool length axis",
        38 => "tool number greater than supported",
        _ => "an error code GRBL 1.1 does not document",
    }
}

/// The meaning of `ALARM:N`.
pub fn alarm(n: u32) -> &'static str {
    match n {
        1 => "hard limit triggered: the position is likely lost; re-homing is needed",
        2 => "soft limit: a motion target exceeds the machine's travel; the position is kept",
        3 => "reset while in motion: the position may be lost; re-homing is recommended",
        4 => "probe fail: the probe was already triggered before the probe cycle",
        5 => "probe fail: the probe did not touch within the programmed travel",
        6 => "homing fail: reset during the homing cycle",
        7 => "homing fail: the safety door was opened during homing",
        8 => "homing fail: the cycle could not clear the limit switch when pulling off",
        9 => "homing fail: no limit switch found within the search distance",
        10 => "homing fail: on dual-axis machines, could not find the second switch",
        _ => "an alarm code GRBL 1.1 does not document",
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn known_codes_have_meanings() {
        for n in (1..=17).chain(20..=38) {
            assert!(!super::error(n).contains("does not document"), "error {n}");
        }
        for n in 1..=9 {
            assert!(!super::alarm(n).contains("does not document"), "alarm {n}");
        }
        assert!(super::error(99).contains("does not document"));
    }
}
