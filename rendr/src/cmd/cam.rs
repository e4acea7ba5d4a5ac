//! `rendr cam`: compute and print a camera's view frame.

use rnd_core::camera::{Camera, CameraSpec};

use crate::args::{def, ArgError, Args, CmdSpec};
use crate::fmt::{g6, list6, matrix};

pub static SPEC: CmdSpec = CmdSpec {
    name: "cam",
    about: "compute camera view frame from parameters",
    info: "Prints the camera inputs and everything derived from them: aspect ratio, \
           distance, the u v n basis, the view-to-world matrix, near/far plane distances \
           from the eye and the image-plane height and width; then converts one view-space \
           4-vector (-v) to world space.",
    response_files: true,
    opts: with_camera_opts!(
        [],
        [def(
            &["v"],
            4,
            "0 0 0 1",
            "x y z w",
            "view-space 4-vector to convert to world space",
        )]
    ),
    pos: &[],
};

/// Reads the camera options (shared with `go`).
pub fn camera_spec(a: &Args) -> Result<CameraSpec, ArgError> {
    let sz = a.get_arr::<u32, 2>("sz")?;
    Ok(CameraSpec {
        from: a.get_arr("fr")?,
        at: a.get_arr("at")?,
        up: a.get_arr("up")?,
        near: a.get("nc")?,
        far: a.get("fc")?,
        fov: a.get("fov")?,
        size: sz,
        orthographic: a.flag("ortho"),
    })
}

pub fn run(a: &Args) -> anyhow::Result<()> {
    let spec = camera_spec(a)?;
    let vv = a.get_arr::<f64, 4>("v")?;
    let c = Camera::new(spec)?;
    let s = &c.spec;
    outln!("rendr cam: ----- input parameters");
    outln!("{} = fr", list6(&s.from));
    outln!("{} = at", list6(&s.at));
    outln!("{} = up", list6(&s.up));
    outln!("{} = nc", g6(s.near));
    outln!("{} = fc", g6(s.far));
    outln!("{} = FOV", g6(s.fov));
    outln!("{} {} = size", s.size[0], s.size[1]);
    outln!("{} = ortho", u8::from(s.orthographic));
    outln!("rendr cam: ----- output parameters");
    outln!("{} = ar", g6(c.ar));
    outln!("{} = |fr-at|=d", g6(c.d));
    outln!("{} = u", list6(&c.u.to_array()));
    outln!("{} = v", list6(&c.v.to_array()));
    outln!("{} = n", list6(&c.n.to_array()));
    out!("VtoW =\n{}", matrix(&c.vtow, g6));
    out!("WtoV =\n{}", matrix(&c.wtov, g6));
    outln!("{} = ncv", g6(c.ncv));
    outln!("{} = fcv", g6(c.fcv));
    outln!("{} = hght", g6(c.hght));
    outln!("{} = wdth", g6(c.wdth));
    let w = c.vtow.mul_vec4(vv);
    outln!("{} (view) -> {} (world)", list6(&vv), list6(&w));
    Ok(())
}
