//! Integration tests: every reproduction of `shared/spec/reproductions.md` must pass.
//! One module per spec section (added as the experiments land).

mod a1_engine {
    #[test]
    fn a15_engine_stand_in() {
        let rep = lifted_tests::a1_engine::run().expect("A1.5 runs");
        println!("{rep}");
        assert!(rep.all_passed(), "{rep}");
    }
}

mod a1_prbs {
    fn assert_rep(rep: lifted_tests::Reproduction) {
        println!("{rep}");
        assert!(rep.all_passed(), "{rep}");
    }
    #[test]
    fn a11_table_i_taps() {
        assert_rep(lifted_tests::a1_prbs::run_a11().expect("A1.1 runs"));
    }
    #[test]
    fn a12_inverse_prbs() {
        assert_rep(lifted_tests::a1_prbs::run_a12().expect("A1.2 runs"));
    }
    #[test]
    fn a13_held_prbs_autocorrelation() {
        assert_rep(lifted_tests::a1_prbs::run_a13().expect("A1.3 runs"));
    }
    #[test]
    fn a14_qmarkov_cover() {
        assert_rep(lifted_tests::a1_prbs::run_a14().expect("A1.4 runs"));
    }
    #[test]
    fn a21_ren_zhu_prbs() {
        assert_rep(lifted_tests::a1_prbs::run_a21().expect("A2.1 runs"));
    }
}

mod a2_closedloop {
    fn assert_rep(rep: lifted_tests::Reproduction) {
        println!("{rep}");
        assert!(rep.all_passed(), "{rep}");
    }
    #[test]
    fn a22_closed_loop_algebra() {
        assert_rep(lifted_tests::a2_closedloop::run_a22().expect("A2.2 runs"));
    }
    #[test]
    fn a23_setup() {
        assert_rep(lifted_tests::a2_closedloop::run_a23().expect("A2.3 runs"));
    }
    #[test]
    fn a25_a26_tables_5_and_6() {
        use lifted_sim::plants::RenZhuPlant;
        let t5 = lifted_tests::a2_closedloop::compute_table(RenZhuPlant::G1).expect("Table 5 runs");
        let t6 = lifted_tests::a2_closedloop::compute_table(RenZhuPlant::G2).expect("Table 6 runs");
        println!(
            "{}",
            lifted_tests::a2_closedloop::tables(&t5, &t6).expect("tables print")
        );
        let r5 = lifted_tests::a2_closedloop::run_a25_from(&t5).expect("A2.5 runs");
        let r6 = lifted_tests::a2_closedloop::run_a26_from(&t6).expect("A2.6 runs");
        println!("{r5}");
        println!("{r6}");
        assert!(r5.all_passed() && r6.all_passed(), "{r5}\n{r6}");
    }
    #[test]
    fn a27_prbs_order() {
        assert_rep(lifted_tests::a2_closedloop::run_a27().expect("A2.7 runs"));
    }
}

mod a2_openloop {
    #[test]
    fn a24_open_loop_eq14() {
        let rep = lifted_tests::a2_openloop::run().expect("A2.4 runs");
        println!("{rep}");
        assert!(rep.all_passed(), "{rep}");
    }
}

mod a3_mpc {
    fn assert_rep(rep: lifted_tests::Reproduction) {
        println!("{rep}");
        assert!(rep.all_passed(), "{rep}");
    }
    #[test]
    fn a310_dmc_gpc_inferential() {
        assert_rep(lifted_tests::a3_mpc::run().expect("A3.10 runs"));
    }
    #[test]
    fn a310_stirred_tank_stand_in() {
        assert_rep(lifted_tests::a3_mpc::run_tank().expect("A3.10 tank runs"));
    }
}

mod a3_dual_rate {
    fn assert_rep(rep: lifted_tests::Reproduction) {
        println!("{rep}");
        assert!(rep.all_passed(), "{rep}");
    }
    #[test]
    fn a311_example_96() {
        assert_rep(lifted_tests::a3_dual_rate::run().expect("A3.11 runs"));
    }
    #[test]
    fn a311_random_triples_and_prop5() {
        assert_rep(lifted_tests::a3_dual_rate::run_random().expect("A3.11 random runs"));
    }
}

mod a3_delay_example {
    #[test]
    fn a36_delay_example() {
        let rep = lifted_tests::a3_delay_example::run().expect("A3.6 runs");
        println!("{rep}");
        assert!(rep.all_passed(), "{rep}");
    }
}

mod a3_lifting {
    fn assert_rep(rep: lifted_tests::Reproduction) {
        println!("{rep}");
        assert!(rep.all_passed(), "{rep}");
    }
    #[test]
    fn a32_lifting_prop1() {
        assert_rep(lifted_tests::a3_lifting::run_a32().expect("A3.2 runs"));
    }
    #[test]
    fn a33_observability() {
        assert_rep(lifted_tests::a3_lifting::run_a33().expect("A3.3 runs"));
    }
    #[test]
    fn a34_delay() {
        assert_rep(lifted_tests::a3_lifting::run_a34().expect("A3.4 runs"));
    }
    #[test]
    fn a35_extraction() {
        assert_rep(lifted_tests::a3_lifting::run_a35().expect("A3.5 runs"));
    }
}

mod a3_polynomial {
    fn assert_rep(rep: lifted_tests::Reproduction) {
        println!("{rep}");
        assert!(rep.all_passed(), "{rep}");
    }
    #[test]
    fn a38_polyphase() {
        assert_rep(lifted_tests::a3_polynomial::run_polyphase().expect("A3.8 polyphase runs"));
    }
    #[test]
    fn a38_vectorized() {
        assert_rep(lifted_tests::a3_polynomial::run_vectorized().expect("A3.8 vectorized runs"));
    }
    #[test]
    fn a38_ccr() {
        assert_rep(lifted_tests::a3_polynomial::run_ccr().expect("A3.8 CCR runs"));
    }
}

mod a3_mimo {
    #[test]
    fn a37_mimo_531() {
        let rep = lifted_tests::a3_mimo::run_531().expect("A3.7 runs");
        println!("{rep}");
        assert!(rep.all_passed(), "{rep}");
    }
    #[test]
    fn a37_mimo_532_standin() {
        let rep = lifted_tests::a3_mimo::run_532().expect("A3.7 stand-in runs");
        println!("{rep}");
        assert!(rep.all_passed(), "{rep}");
    }
}

mod a3_multirate_iv {
    #[test]
    fn a39_multirate_stirred_tank() {
        let rep = lifted_tests::a3_multirate_iv::run().expect("A3.9 multirate runs");
        println!("{rep}");
        assert!(rep.all_passed(), "{rep}");
    }
}

mod a3_subspace {
    #[test]
    fn a31_stirred_tank_cva_n4sid_moesp() {
        let rep = lifted_tests::a3_subspace::run().expect("A3.1 runs");
        println!("{rep}");
        assert!(rep.all_passed(), "{rep}");
    }
}

mod a3_iv {
    #[test]
    fn a39_closed_loop_iv_siso() {
        let rep = lifted_tests::a3_iv::run().expect("A3.9 runs");
        println!("{rep}");
        assert!(rep.all_passed(), "{rep}");
    }

    #[test]
    fn a39_closed_loop_bias_of_plain_n4sid() {
        let rep = lifted_tests::a3_iv::run_bias().expect("A3.9 bias experiment runs");
        println!("{rep}");
        assert!(rep.all_passed(), "{rep}");
    }
}
