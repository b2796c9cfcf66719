//! `StarNetConfig::init_seeded` in a process of its own: Burn's device generator is shared by
//! the whole process, so beside the library's other tests (which draw from it) the check could
//! not tell a fault from their draws.

use starnet_model::backend::default_device;
use starnet_model::export::named_tensors;
use starnet_model::nn::StarNetConfig;

#[test]
fn seeded_initialisation_depends_on_the_seed_alone_even_from_threads_at_once() {
    let dev = default_device();
    let cfg = StarNetConfig::small_car();
    let weights = |seed| named_tensors(&cfg.init_seeded(&dev, seed));
    let (a, b) = (weights(7), weights(8));
    assert_eq!(weights(7), a);
    assert_ne!(a, b);
    // Four trainers' worth of initialisations racing: each still gets its seed's weights.
    let raced: Vec<_> = std::thread::scope(|s| {
        let handles: Vec<_> = [7, 8, 7, 8].map(|seed| s.spawn(move || weights(seed))).into();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert!(raced[0] == a && raced[2] == a && raced[1] == b && raced[3] == b);
}
