mod common;
use common::*;
use rtseq_motor::app::{Fault, FaultPlan};

fn dbg(plan: FaultPlan, safety: bool) {
    let mut w = World::new(plan, safety);
    let end = w.run();
    println!("{}", w.show());
    println!("end {end} {:#?}", w.cs.summary());
    println!("{:?}", w.cs.status());
}

#[test]
fn dbg_fe() {
    dbg(FaultPlan::NONE.with(Fault::FollowingError { at: ms(1500) }), false);
}
#[test]
fn dbg_es() {
    dbg(FaultPlan::NONE.with(Fault::EndStop { at: ms(1500) }), false);
}
#[test]
fn dbg_pause() {
    dbg(FaultPlan::NONE.with_pause(ms(1500), ms(2000)), false);
}
#[test]
fn dbg_oc() {
    dbg(FaultPlan::NONE.with(Fault::OverCurrent { at: ms(1500) }), true);
}
#[test]
fn dbg_none_safety() {
    dbg(FaultPlan::NONE, true);
}
