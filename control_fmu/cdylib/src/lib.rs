//! The second level's controller exported as the FMI 2.0 and FMI 3.0 Co-Simulation FMU `control_fmu`.

fmi::export_fmu!(control_fmu::ControlFmu);
fmi::export_fmu3!(control_fmu::ControlFmu);
