//! The zoo model `feedthrough` exported as the FMI 2.0 and FMI 3.0 Co-Simulation FMU `feedthrough`.

fmi::export_fmu!(zoo_fmus::feedthrough::FeedthroughFmu);
fmi::export_fmu3!(zoo_fmus::feedthrough::FeedthroughFmu);
