//! One Clique-style proof-of-authority node per robot, gossiping over the radio graph
//! (SPEC.md section 3). Placeholder: the ledger issue fills this module in (`ledger/`).
