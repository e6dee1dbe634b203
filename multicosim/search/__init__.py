"""Testing a system against its requirements: STL requirements and their robustness
([`requirements`][multicosim.search.requirements]), campaigns over a design of experiments
([`campaign`][multicosim.search.campaign]), falsifying searches
([`falsify`][multicosim.search.falsify], [`taliro`][multicosim.search.taliro]) and Hypothesis
strategies ([`strategies`][multicosim.search.strategies]).
"""
