use super::common::*;
use lifted_lti::Dataset;
use lifted_lti::identify::Identifier;
use lifted_subspace::*;

#[test]
fn identifier_trait_on_datasets() {
    let g = random_system(5, &[0.8, 0.5], &[], 1, 1, false);
    let u = rbs(3, 600, 1);
    let y = sim(&g, &u, None);
    let data = Dataset::single_rate(1.0, u, y).unwrap();
    let id = SubspaceIdentifier {
        options: SubspaceOptions {
            order: OrderSelection::Fixed(2),
            method: Method::Cva,
            ..Default::default()
        },
    };
    assert_eq!(id.name(), "CVA");
    let out = id.identify(&[data.clone(), data]).unwrap();
    assert!(freq_error(&out.model, &g) < 1e-8);
    assert_eq!(out.diagnostics.order, 2);
    assert!(matches!(id.identify(&[]), Err(Error::Data(_))));
}
