//! The closed-loop identification set-ups of Ren & Zhu (2009, §3): which
//! excitation is logged and which recovery formula (10)–(12) applies.

/// The closed-loop identification set-up (Ren & Zhu 2009, §3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Setup {
    /// Eq. (10): both r₁ and r₂ excited (joint input–output approach).
    General,
    /// Eq. (11): r₁ only, K known (indirect approach).
    Controller,
    /// Eq. (12): r₂ only, K known (indirect approach).
    Compensator,
}

impl Setup {
    /// All three, in the paper's order.
    pub const ALL: [Setup; 3] = [Setup::General, Setup::Controller, Setup::Compensator];

    /// The equation number of the recovery formula (10, 11 or 12).
    pub fn equation(self) -> u32 {
        match self {
            Setup::General => 10,
            Setup::Controller => 11,
            Setup::Compensator => 12,
        }
    }

    /// Whether the set-up needs excitation at the reference r₁.
    pub fn needs_r1(self) -> bool {
        matches!(self, Setup::General | Setup::Controller)
    }

    /// Whether the set-up needs excitation at the plant input r₂.
    pub fn needs_r2(self) -> bool {
        matches!(self, Setup::General | Setup::Compensator)
    }

    /// Whether the recovery needs the controller K.
    pub fn needs_controller(self) -> bool {
        !matches!(self, Setup::General)
    }
}
