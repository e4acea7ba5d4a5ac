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
        fr: a.get_arr("fr")?,
        at: a.get_arr("at")?,
        up: a.get_arr("up")?,
        nc: a.get("nc")?,
        fc: a.get("fc")?,
        fov: a.get("fov")?,
        size: sz,
        ortho: a.flag("ortho"),
    })
}

pub fn run(a: &Args) -> anyhow::Result<()> {
    let spec = camera_spec(a)?;
    let vv = a.get_arr::<f64, 4>("v")?;
    let c = Camera::new(spec)?;
    let s = &c.spec;
    println!("rendr cam: ----- input parameters");
    println!("{} = fr", list6(&s.fr));
    println!("{} = at", list6(&s.at));
    println!("{} = up", list6(&s.up));
    println!("{} = nc", g6(s.nc));
    println!("{} = fc", g6(s.fc));
    println!("{} = FOV", g6(s.fov));
    println!("{} {} = size", s.size[0], s.size[1]);
    println!("{} = ortho", u8::from(s.ortho));
    println!("rendr cam: ----- output parameters");
    println!("{} = ar", g6(c.ar));
    println!("{} = |fr-at|=d", g6(c.d));
    println!("{} = u", list6(&c.u.to_array()));
    println!("{} = v", list6(&c.v.to_array()));
    println!("{} = n", list6(&c.n.to_array()));
    print!("VtoW =\n{}", matrix(&c.vtow, g6));
    print!("WtoV =\n{}", matrix(&c.wtov, g6));
    println!("{} = ncv", g6(c.ncv));
    println!("{} = fcv", g6(c.fcv));
    println!("{} = hght", g6(c.hght));
    println!("{} = wdth", g6(c.wdth));
    let w = c.vtow.mul_vec4(vv);
    println!("{} (view) -> {} (world)", list6(&vv), list6(&w));
    Ok(())
}
