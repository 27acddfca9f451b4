//! The zoo model `dahlquist` exported as the FMI 2.0 and FMI 3.0 Co-Simulation FMU `dahlquist`.

fmi::export_fmu!(zoo_fmus::dahlquist::DahlquistFmu);
fmi::export_fmu3!(zoo_fmus::dahlquist::DahlquistFmu);
