//! The zoo model `bouncing_ball` exported as the FMI 2.0 and FMI 3.0 Co-Simulation FMU `bouncing_ball`.

fmi::export_fmu!(zoo_fmus::bouncing_ball::BouncingBallFmu);
fmi::export_fmu3!(zoo_fmus::bouncing_ball::BouncingBallFmu);
