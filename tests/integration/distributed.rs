//! Distributed renders: the volume split into slabs over ranks (threads joined by channels
//! here, MPI processes in `mpi.rs`) against the single-process render of the same options.

use crate::common::{render, renderer};
use crate::volume_render::hdr_blobs;
use hdrvis::gpu::BackendChoice;
use hdrvis::model::{Axis, Camera, LutTransfer, Scale, TransferFunction, Volume};
use hdrvis::render::distributed::{ChannelExchange, Exchange};
use hdrvis::render::session::RenderSession;
use hdrvis::render::{FilterMode, RenderPath, VolumeRenderOptions, VolumeSource};
use std::sync::Arc;

/// `source` rendered by `n` ranks on threads; every rank's image (they must agree).
fn render_split(
    n: usize,
    source: &VolumeSource,
    opts: &VolumeRenderOptions,
) -> hdrvis::Result<Vec<Vec<[f32; 4]>>> {
    let ctx = renderer(BackendChoice::Vulkan).context().clone();
    std::thread::scope(|s| {
        let handles: Vec<_> = ChannelExchange::group(n)
            .into_iter()
            .map(|ex| {
                let ctx = ctx.clone();
                s.spawn(move || {
                    let world: Arc<dyn Exchange> = Arc::new(ex);
                    let session = RenderSession::with_context(ctx, 0).with_cluster(world);
                    let r = session.render_volume_detailed(source, opts)?;
                    assert_eq!(r.path, RenderPath::Distributed { ranks: n });
                    Ok(r.image.pixels.clone())
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    })
}

/// Largest channel difference over the image's peak colour channel.
fn worst_over_peak(split: &[[f32; 4]], single: &[[f32; 4]]) -> f64 {
    let peak = single
        .iter()
        .flat_map(|p| p[..3].iter())
        .fold(0.0f32, |m, &v| m.max(v)) as f64;
    assert!(peak > 0.0, "the reference image is black");
    split
        .iter()
        .zip(single)
        .flat_map(|(a, b)| (0..4).map(move |c| (a[c] - b[c]).abs() as f64))
        .fold(0.0, f64::max)
        / peak
}

fn log_lut() -> TransferFunction {
    TransferFunction::Lut(LutTransfer {
        scale: Scale::Log10,
        domain: Some([1e-4, 10.0]),
        colormap: "magma".into(),
        emission: vec![[0.0, -1.0], [1.0, 1.0]],
        opacity: vec![[0.0, -4.0], [0.6, -2.0], [1.0, -0.5]],
        ..Default::default()
    })
}

/// The blobs with a hole of missing values across z = 16, the boundary of two and of four
/// slabs of 32 slices.
fn blobs_with_hole() -> Volume {
    let mut v = hdr_blobs(32);
    for k in 14..18 {
        for j in 8..20 {
            for i in 6..18 {
                let idx = v.index(i, j, k);
                v.data[idx] = f32::NAN;
            }
        }
    }
    v
}

fn options(camera: Camera, tf: TransferFunction) -> VolumeRenderOptions {
    let mut o = VolumeRenderOptions::new(camera, tf);
    (o.width, o.height, o.step) = (40, 32, 0.7);
    o.filter = FilterMode::Exact;
    // The split never stops rays early (a rank cannot know what lies in front of it).
    o.early_exit = 0.0;
    o.background = [0.02, 0.01, 0.03];
    o
}

#[test]
fn slabs_on_two_three_and_four_ranks_give_the_single_process_image() {
    let vol = blobs_with_hole();
    let bounds = vol.bounds();
    let cameras = [
        (
            "perspective",
            Camera::orbit(&bounds, 35.0, 25.0, 40.0).unwrap(),
        ),
        (
            "from below",
            Camera::orbit(&bounds, 20.0, -60.0, 40.0).unwrap(),
        ),
        ("axis z", Camera::axis(Axis::Z, &bounds)),
        ("axis x", Camera::axis(Axis::X, &bounds)),
    ];
    let tfs = [
        ("log LUT", log_lut()),
        (
            "emission-absorption",
            TransferFunction::emission_absorption(0.4, 0.3).unwrap(),
        ),
    ];
    let source = VolumeSource::Memory(Arc::new(vol.clone()));
    for (cam_name, cam) in &cameras {
        for (tf_name, tf) in &tfs {
            let mut o = options(*cam, tf.clone());
            o.jitter = cam_name == &"perspective";
            let single = render(BackendChoice::Vulkan, &vol, &o).pixels;
            for n in [2, 3, 4] {
                let images = render_split(n, &source, &o).unwrap();
                assert!(images.iter().all(|im| im == &images[0]), "ranks disagree");
                let worst = worst_over_peak(&images[0], &single);
                assert!(
                    worst < 1e-5,
                    "{cam_name}, {tf_name}, {n} ranks: worst difference {worst:.2e} of the peak"
                );
            }
        }
    }
}

#[test]
fn shaded_slabs_match_and_bad_splits_are_refused() {
    let vol = hdr_blobs(24);
    let cam = Camera::orbit(&vol.bounds(), 35.0, 25.0, 40.0).unwrap();
    let mut o = options(cam, log_lut());
    o.shading = Some(Default::default());
    let single = render(BackendChoice::Vulkan, &vol, &o).pixels;
    let source = VolumeSource::Memory(Arc::new(vol.clone()));
    let images = render_split(3, &source, &o).unwrap();
    let worst = worst_over_peak(&images[0], &single);
    assert!(worst < 1e-5, "shaded, 3 ranks: {worst:.2e} of the peak");

    // More ranks than slices: one line naming the volume and the slice count, on every rank.
    let thin = Volume::from_fn("thin", [8, 8, 3], |x, _, _| x).unwrap();
    let thin = VolumeSource::Memory(Arc::new(thin));
    let ctx = renderer(BackendChoice::Vulkan).context().clone();
    let errs: Vec<String> = ChannelExchange::group(4)
        .into_iter()
        .map(|ex| {
            let world: Arc<dyn Exchange> = Arc::new(ex);
            let session = RenderSession::with_context(ctx.clone(), 0).with_cluster(world);
            session.render_volume(&thin, &o).unwrap_err().to_string()
        })
        .collect();
    for e in &errs {
        assert!(
            e.contains("4 ranks cannot share thin: it has 3 z-slices") && !e.contains('\n'),
            "{e}"
        );
    }
    let mut u8_opts = o.clone();
    u8_opts.precision = hdrvis::render::Precision::U8;
    let err = render_split(2, &source, &u8_opts).unwrap_err().to_string();
    assert!(
        err.starts_with("precision: a render split over 2 ranks"),
        "{err}"
    );
}

/// The mantle's shell edges: a sample on a voxel boundary beside a missing voxel is missing or not
/// depending on the last bit of its position, so every rank must place each sample exactly where
/// the single process does (its interior segments on the same arithmetic sequence).
#[test]
fn slabs_of_the_mantle_place_their_samples_where_one_process_does() {
    use hdrvis::datasets::mantle::{generate, MantleField, MantleFields, MantleOptions};
    let n = 65;
    let m = generate(
        &MantleOptions {
            n,
            fields: MantleFields::only(MantleField::Fluctuation),
            ..Default::default()
        },
        &mut |_| Ok(()),
    )
    .unwrap();
    let h = 2.0 / n as f64;
    let vol = Volume::new("mantle", [n; 3], [h; 3], [-1.0; 3], m.fluctuation).unwrap();
    let tf = TransferFunction::Lut(hdrvis::bench::mantle_fig5_tf());
    let mut o = options(Camera::orbit(&vol.bounds(), 35.0, 20.0, 25.0).unwrap(), tf);
    (o.width, o.height, o.step) = (128, 128, 1.0);
    let single = render(BackendChoice::Vulkan, &vol, &o).pixels;
    let source = VolumeSource::Memory(Arc::new(vol.clone()));
    for ranks in [2, 3] {
        let images = render_split(ranks, &source, &o).unwrap();
        let worst = worst_over_peak(&images[0], &single);
        assert!(worst < 1e-5, "{ranks} ranks: {worst:.2e} of the peak");
    }
}
