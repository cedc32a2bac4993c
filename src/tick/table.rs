//! The monitor table a sequencer is ticked with: the first non-empty one a due tick
//! brings is bound to the sequencer (both ways), and a tick with another is refused.

use crate::lock::Lock;
use crate::model::set::Words;
use crate::sequencer::State;
use crate::{Monitors, Sequencer};

impl<C, const N: usize, const T: usize, const W: usize, const B: usize> State<C, N, T, W, B> {
    /// Whether a due tick with `table` may take the due polls: the table is this
    /// sequencer's (it is where the sequencer's table is, and bound to this sequencer's
    /// tag, which moves with the sequencer), or the first non-empty table a due tick came
    /// with, which is bound here (both ways); or an empty table while none is bound (it
    /// evaluates nothing, and no table misses the polls). A table that another sequencer
    /// ticks, or any table at another place once one is bound, may not: the polls it took
    /// would be lost to the table that holds their monitors. Nor may a table with an
    /// owner beyond this sequencer's sets (an id of 32 or more in a sequencer of one
    /// word): its owners are another sequencer's ids, and in this one's sets they would
    /// read as the ids of the same bit in a lower word. A table made anew in the place of
    /// the bound one is bound again, and so is the bound one after a monitor was added to
    /// it (`Monitors::add` unbinds it), its owners checked again.
    #[inline(always)]
    pub(super) fn takes_polls<const M: usize, K>(
        &mut self,
        table: &mut Monitors<'_, C, M, K>,
    ) -> bool {
        let here = core::ptr::from_ref(table).addr();
        if table.ticked_by == self.tag && self.monitor_table == here {
            return true;
        }
        if self.is_foreign(table) {
            return false;
        }
        if !table.is_empty() {
            if !table.groups.owner_words.without(Words::below(B)).is_empty() {
                return false;
            }
            self.monitor_table = here;
            table.ticked_by = self.tag;
        }
        true
    }

    /// Whether `table` may not be ticked by this sequencer: another table is bound here,
    /// or `table` is bound to another sequencer.
    #[inline(always)]
    fn is_foreign<const M: usize, K>(&self, table: &Monitors<'_, C, M, K>) -> bool {
        let here = core::ptr::from_ref(table).addr();
        let ours = self.monitor_table == 0 || self.monitor_table == here;
        !ours || (table.ticked_by != 0 && table.ticked_by != self.tag)
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// Whether a due tick with `table` would be refused with
    /// [`Error::ForeignMonitorTable`](crate::Error::ForeignMonitorTable): the simulator's
    /// first start asks.
    #[cfg(feature = "std")]
    pub(crate) fn is_foreign_table<const M: usize, K>(
        &self,
        table: &Monitors<'_, C, M, K>,
    ) -> bool {
        self.with(|s| s.is_foreign(table))
    }

    /// `table`, bound to this sequencer, is dropped (with the simulator that owned it):
    /// the next table that comes with a due tick is the sequencer's.
    #[cfg(feature = "std")]
    pub(crate) fn release_table<const M: usize, K>(&self, table: &Monitors<'_, C, M, K>) {
        let here = core::ptr::from_ref(table).addr();
        self.with(|s| {
            if s.monitor_table == here {
                s.monitor_table = 0;
            }
        });
    }
}
