//! A counter that starts at 1 and goes up by one at every multiple of its period (a time event,
//! wherever it falls in a step), and ends the simulation when it reaches its final count.

/// Period and final count.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stair {
    /// Time between increments (s, > 0).
    pub period: f64,
    /// The count at which the model ends (≥ 1).
    pub final_count: i32,
}

/// What a step of the counter reached.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StairStep {
    /// The step's end, with this count.
    Reached(i32),
    /// The final count was reached at `time`, inside or at the end of the step: the model ends there.
    Ended { time: f64 },
}

impl Stair {
    /// Event times that land on a time within this fraction of the period count as reached
    /// (communication points drift by rounding: 10 steps of 0.1 make 0.9999999999999999).
    const TIME_TOLERANCE: f64 = 1e-9;

    /// The count at time `t` ≥ 0.
    pub fn count_at(&self, t: f64) -> i32 {
        let events = (t / self.period + Self::TIME_TOLERANCE).floor();
        (1.0 + events).min(f64::from(self.final_count)) as i32
    }

    /// When the count reaches its final value.
    pub fn end_time(&self) -> f64 {
        f64::from(self.final_count - 1) * self.period
    }

    /// The step from `t` to `t + h`.
    pub fn step(&self, t: f64, h: f64) -> StairStep {
        let end = self.end_time();
        if end <= t + h + Self::TIME_TOLERANCE * self.period {
            StairStep::Ended { time: end.max(t) }
        } else {
            StairStep::Reached(self.count_at(t + h))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_one_per_period_from_one() {
        let s = Stair { period: 1.0, final_count: 10 };
        assert_eq!(s.count_at(0.0), 1);
        assert_eq!(s.count_at(0.999), 1);
        assert_eq!(s.count_at(0.1 * 10.0 - 1e-16), 2, "a rounded communication point counts");
        assert_eq!(s.count_at(3.5), 4);
        assert_eq!(s.count_at(100.0), 10, "never past the final count");
    }

    #[test]
    fn ends_inside_the_step_that_holds_the_final_event() {
        let s = Stair { period: 1.0, final_count: 10 };
        assert_eq!(s.step(8.0, 0.4), StairStep::Reached(9));
        assert_eq!(s.step(8.8, 0.4), StairStep::Ended { time: 9.0 });
        assert_eq!(s.step(8.5, 0.5), StairStep::Ended { time: 9.0 }, "at the step's end too");
        assert_eq!(Stair { period: 0.5, final_count: 1 }.step(0.0, 0.1), StairStep::Ended { time: 0.0 });
    }
}
