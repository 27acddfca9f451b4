//! A ball falling under gravity onto the ground at height 0, where it bounces with a coefficient
//! of restitution. Between impacts its motion is a parabola, so a step is solved exactly: the
//! impact times inside the step are found from the quadratic, not at step boundaries.

use serde::{Deserialize, Serialize};

/// The ball's world: gravity, restitution and the rebound speed below which it comes to rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BouncingBall {
    /// Gravitational acceleration (m/s², ≥ 0, pulling towards the ground).
    pub g: f64,
    /// Coefficient of restitution in [0, 1]: rebound speed / impact speed.
    pub e: f64,
    /// A rebound slower than this (m/s, ≥ 0) leaves the ball resting on the ground.
    pub v_min: f64,
}

/// The ball's state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Ball {
    /// Height above the ground (m, ≥ 0) and vertical velocity (m/s, up positive).
    pub h: f64,
    pub v: f64,
    /// Impacts so far.
    pub bounces: i32,
    /// At rest on the ground for good.
    pub resting: bool,
}

impl BouncingBall {
    /// Time until the ball at height `h` ≥ 0 moving at `v` reaches the ground (infinite if it
    /// never does). The root of `h + v s − g s²/2 = 0` is written so that nothing cancels.
    pub fn time_to_impact(&self, h: f64, v: f64) -> f64 {
        let g = self.g;
        let root = (v * v + 2.0 * g * h).sqrt();
        if v >= 0.0 { if g > 0.0 { (v + root) / g } else { f64::INFINITY } } else { 2.0 * h / (root - v) }
    }

    /// Advances `ball` by `dt`, handling every impact inside the interval at its exact time.
    pub fn advance(&self, ball: &mut Ball, dt: f64) {
        let mut left = dt;
        while !ball.resting {
            let s = self.time_to_impact(ball.h, ball.v);
            if s > left {
                ball.h = (ball.h + ball.v * left - 0.5 * self.g * left * left).max(0.0);
                ball.v -= self.g * left;
                return;
            }
            let impact_speed = ball.v - self.g * s;
            ball.h = 0.0;
            ball.v = -self.e * impact_speed;
            ball.bounces += 1;
            left -= s;
            if ball.v <= self.v_min {
                ball.resting = true;
            }
        }
        (ball.h, ball.v) = (0.0, 0.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const WORLD: BouncingBall = BouncingBall { g: 9.81, e: 0.7, v_min: 0.1 };

    fn dropped(h: f64) -> Ball {
        Ball { h, v: 0.0, bounces: 0, resting: false }
    }

    #[test]
    fn free_fall_until_the_first_impact_is_exact() {
        let mut b = dropped(1.0);
        WORLD.advance(&mut b, 0.3);
        assert!((b.h - (1.0 - 0.5 * 9.81 * 0.09)).abs() < 1e-15 && (b.v + 9.81 * 0.3).abs() < 1e-15, "{b:?}");
        assert_eq!(b.bounces, 0);
    }

    #[test]
    fn an_impact_inside_a_step_is_located_exactly() {
        // first impact at t1 = sqrt(2/g), rebound at e·g·t1, then a parabola
        let t1 = (2.0 / 9.81_f64).sqrt();
        let v1 = 0.7 * 9.81 * t1;
        let t = 0.5; // t1 = 0.4515… lies inside the single step [0, 0.5]
        let mut b = dropped(1.0);
        WORLD.advance(&mut b, t);
        let s = t - t1;
        assert_eq!(b.bounces, 1);
        assert!((b.h - (v1 * s - 0.5 * 9.81 * s * s)).abs() < 1e-15, "{b:?}");
        assert!((b.v - (v1 - 9.81 * s)).abs() < 1e-14, "{b:?}");
    }

    #[test]
    fn the_step_size_does_not_change_the_answer() {
        let run = |n: usize| {
            let mut b = dropped(1.0);
            for _ in 0..n {
                WORLD.advance(&mut b, 2.0 / n as f64);
            }
            b
        };
        let (one, many) = (run(1), run(1000));
        assert_eq!(one.bounces, many.bounces);
        assert!((one.h - many.h).abs() < 1e-12 && (one.v - many.v).abs() < 1e-12, "{one:?} vs {many:?}");
    }

    #[test]
    fn the_ball_comes_to_rest_after_finitely_many_bounces() {
        // impact speeds v0·eᵏ; it rests at the first rebound below v_min
        let v0 = (2.0 * 9.81_f64).sqrt();
        let expected = (1..).find(|&k| v0 * 0.7_f64.powi(k) <= 0.1).unwrap();
        let mut b = dropped(1.0);
        WORLD.advance(&mut b, 10.0);
        assert!(b.resting && b.h == 0.0 && b.v == 0.0, "{b:?}");
        assert_eq!(b.bounces, expected);
        // without restitution it stays down at once; a ball on the ground does not move
        let mut b = dropped(1.0);
        BouncingBall { e: 0.0, ..WORLD }.advance(&mut b, 1.0);
        assert!(b.resting && b.bounces == 1);
        let mut b = dropped(0.0);
        BouncingBall { v_min: 0.0, ..WORLD }.advance(&mut b, 1.0);
        assert!(b.resting && b.bounces == 1 && b.h == 0.0);
    }

    #[test]
    fn time_to_impact_rising_falling_and_weightless() {
        assert!((WORLD.time_to_impact(0.0, 9.81) - 2.0).abs() < 1e-15);
        let s = WORLD.time_to_impact(1e-12, -3.0);
        assert!((s * 3.0e12 - 1.0).abs() < 1e-9, "{s:e}: no cancellation");
        let w = BouncingBall { g: 0.0, ..WORLD };
        assert_eq!(w.time_to_impact(1.0, 0.5), f64::INFINITY);
        assert_eq!(w.time_to_impact(1.0, -0.5), 2.0);
    }
}
