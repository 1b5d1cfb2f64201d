mod bsdf;
mod coherence;
mod coherence_scenes;
mod network_build;
mod network_common;
mod network_relight;
mod network_scenes;
mod network_transport;
