use super::{ParamError, Params};

#[test]
fn check_accepts_the_defaults_and_every_variant_and_rejects_what_turns_gvs_off() {
    assert_eq!(Params::default().check(), Ok(()));
    for v in super::super::Variant::ALL {
        assert_eq!(v.params(Params::default()).check(), Ok(()), "{}", v.name());
    }
    let with = |f: fn(&mut Params)| {
        let mut p = Params::default();
        f(&mut p);
        p.check()
    };
    assert!(matches!(with(|p| p.eps = f32::NAN), Err(ParamError::Eps(_))));
    assert_eq!(with(|p| p.eps = 0.0), Err(ParamError::Eps(0.0)));
    assert_eq!(with(|p| p.eps = 2.0), Err(ParamError::Eps(2.0)));
    assert_eq!(with(|p| p.eps = 1.0), Ok(()));
    assert!(matches!(with(|p| p.disc = f32::NAN), Err(ParamError::Disc(_))));
    assert_eq!(with(|p| p.disc = -0.1), Err(ParamError::Disc(-0.1)));
    assert_eq!(with(|p| p.disc = 1.0), Err(ParamError::Disc(1.0)));
    assert_eq!(with(|p| p.disc = 0.0), Ok(()));
    assert_eq!(with(|p| p.adt = Some(f32::INFINITY)), Err(ParamError::Adt(f32::INFINITY)));
    assert_eq!(with(|p| p.adt = Some(0.0)), Err(ParamError::Adt(0.0)));
    assert_eq!(with(|p| p.adt = Some(1e-4)), Ok(()));
}
