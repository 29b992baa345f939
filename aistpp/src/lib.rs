//! qean-aistpp: the datasets (AIST++; FineDance and a plain folder of dances through `layout`). Sequence and music names (genres, tempo priors), the official splits
//! and ignore list, dataset directories, training windows and their sampler, the music-feature cache, and
//! `inspect` for any file or directory of the dataset, `parallel` for work over its files side by side; FineDance motion files (`finedance`); and a user's text–motion set in the HumanML3D layout
//! (`text_set`).

pub mod dataset;
pub mod feature_cache;
pub mod finedance;
pub mod inspect;
pub mod layout;
pub mod names;
pub mod parallel;
pub mod text_set;
pub mod windows;
