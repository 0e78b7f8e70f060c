//! Linear steady state of the assembly (method `linear-frf`): the assembled
//! linear frequency response of structure + attachments (all modes), with the
//! closed forms `eq:fhfhNull` and `eq:forcedrop` beside it.
//! (filled in by the attachment work)
