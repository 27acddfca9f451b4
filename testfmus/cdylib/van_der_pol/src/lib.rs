//! The zoo model `van_der_pol` exported as the FMI 2.0 and FMI 3.0 Co-Simulation FMU `van_der_pol`.

fmi::export_fmu!(zoo_fmus::van_der_pol::VanDerPolFmu);
fmi::export_fmu3!(zoo_fmus::van_der_pol::VanDerPolFmu);
