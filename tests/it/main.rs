//! Integration tests: drive the real `facslab` binary on files in a temporary directory.

mod analyze;
mod appearance;
mod backends;
mod balance;
mod browser;
mod cli;
mod curves;
mod e2e;
mod edge;
mod golden;
mod laugh;
mod labels;
mod laughs_study;
mod psych_ds;
mod render;
mod scale;
mod server;
mod speech;
mod power;
mod stimuli;
mod study;
mod studio;
mod templates;
mod tidy;
